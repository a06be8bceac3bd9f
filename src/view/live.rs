//! The live page's pose stream: every page connected to `/live` (a WebSocket) gets each
//! frame the avatar thread broadcasts, as JSON text. A page that reads too slowly loses
//! frames (counted), never holds up the others or the avatar; a page that goes away is
//! forgotten, and one that comes back (a reload, a reconnect) simply joins again.

use crossbeam_channel::{Receiver, Sender, TrySendError};
use std::net::TcpStream;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::{Arc, Mutex};
use tungstenite::protocol::Role;
use tungstenite::{Message, WebSocket};

/// Frames a page may fall behind before it loses some.
const QUEUE: usize = 8;

/// The pages connected to the stream.
#[derive(Debug, Default)]
pub struct LiveHub {
    clients: Mutex<Vec<Sender<Arc<str>>>>,
    /// Frames broadcast.
    pub frames: AtomicU64,
    /// Pages that have connected.
    pub connections: AtomicU64,
    /// Frames a slow page did not get.
    pub dropped: AtomicU64,
}

impl LiveHub {
    /// Send one frame to every connected page.
    pub fn broadcast(&self, text: Arc<str>) {
        self.frames.fetch_add(1, Relaxed);
        let mut clients = self.clients.lock().unwrap_or_else(|e| e.into_inner());
        clients.retain(|c| match c.try_send(Arc::clone(&text)) {
            Ok(()) => true,
            Err(TrySendError::Full(_)) => {
                self.dropped.fetch_add(1, Relaxed);
                true
            }
            Err(TrySendError::Disconnected(_)) => false,
        });
    }

    /// Pages connected now.
    pub fn connected(&self) -> usize {
        self.clients.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    fn join(&self) -> Receiver<Arc<str>> {
        let (tx, rx) = crossbeam_channel::bounded(QUEUE);
        self.clients.lock().unwrap_or_else(|e| e.into_inner()).push(tx);
        self.connections.fetch_add(1, Relaxed);
        rx
    }
}

impl super::http::SocketHandler for LiveHub {
    /// Stream frames to one page whose WebSocket handshake has been answered, until it goes.
    fn serve(&self, stream: TcpStream) {
        let frames = self.join();
        let _ = stream.set_nodelay(true);
        // A page that stops reading (a frozen tab) ends its connection instead of holding
        // this thread for ever.
        let _ = stream.set_write_timeout(Some(std::time::Duration::from_secs(5)));
        let mut ws = WebSocket::from_raw_socket(stream, Role::Server, None);
        for text in frames.iter() {
            if ws.send(Message::text(text.to_string())).is_err() {
                return;
            }
        }
    }
}
