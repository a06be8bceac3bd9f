//! Carrying encoded messages: an in-process channel, or UDP to a sound process elsewhere.
//!
//! Both carry the OSC bytes of [`super::encode`] unchanged, so the receiving side decodes the
//! same packets whichever way they came. Neither is used on the audio thread: the receiver
//! decodes and hands the audio thread plain events.

use crossbeam_channel::{Receiver, RecvTimeoutError, Sender, TrySendError};
use std::io;
use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::time::Duration;

/// The sending end of a transport.
pub trait PacketSender: Send {
    /// Send one packet (one OSC message or bundle). Never blocks: a full channel is an error.
    fn send(&mut self, packet: &[u8]) -> Result<(), TransportError>;
}

/// The receiving end of a transport.
pub trait PacketReceiver: Send {
    /// Wait up to `timeout` for a packet; `Ok(None)` if none came.
    fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<&[u8]>, TransportError>;
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TransportError {
    #[error("the message channel is full (the receiver is not keeping up)")]
    Full,
    #[error("the other end of the message channel is gone")]
    Disconnected,
    #[error("UDP message transport: {0}")]
    Io(#[from] io::Error),
}

/// An in-process channel of at most `capacity` packets in flight. Packet buffers go back to
/// the sender once read, so a steady stream of messages does not allocate.
pub fn channel(capacity: usize) -> (ChannelSender, ChannelReceiver) {
    let (tx, rx) = crossbeam_channel::bounded(capacity);
    let (free_tx, free_rx) = crossbeam_channel::bounded(capacity + 1);
    (ChannelSender { tx, free: free_rx }, ChannelReceiver { rx, free: free_tx, current: Vec::new() })
}

pub struct ChannelSender {
    tx: Sender<Vec<u8>>,
    free: Receiver<Vec<u8>>,
}

pub struct ChannelReceiver {
    rx: Receiver<Vec<u8>>,
    free: Sender<Vec<u8>>,
    /// The packet last handed out (returned to the sender on the next call).
    current: Vec<u8>,
}

impl PacketSender for ChannelSender {
    fn send(&mut self, packet: &[u8]) -> Result<(), TransportError> {
        let mut buf = self.free.try_recv().unwrap_or_default();
        buf.clear();
        buf.extend_from_slice(packet);
        self.tx.try_send(buf).map_err(|e| match e {
            TrySendError::Full(_) => TransportError::Full,
            TrySendError::Disconnected(_) => TransportError::Disconnected,
        })
    }
}

impl PacketReceiver for ChannelReceiver {
    fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<&[u8]>, TransportError> {
        match self.rx.recv_timeout(timeout) {
            Ok(packet) => {
                let used = std::mem::replace(&mut self.current, packet);
                let _ = self.free.try_send(used); // the sender may be gone: then it is just freed
                Ok(Some(&self.current))
            }
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(TransportError::Disconnected),
        }
    }
}

/// Sends each packet as one UDP datagram to a fixed address.
pub struct UdpSender {
    socket: UdpSocket,
}

impl UdpSender {
    /// A socket on an ephemeral local port, sending to `to` (for example "127.0.0.1:9000").
    pub fn connect(to: impl ToSocketAddrs) -> io::Result<UdpSender> {
        let to = to
            .to_socket_addrs()?
            .next()
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "no address to send to"))?;
        let local: SocketAddr = if to.is_ipv4() { ([0, 0, 0, 0], 0).into() } else { ([0u16; 8], 0).into() };
        let socket = UdpSocket::bind(local)?;
        socket.connect(to)?;
        Ok(UdpSender { socket })
    }
}

impl PacketSender for UdpSender {
    fn send(&mut self, packet: &[u8]) -> Result<(), TransportError> {
        match self.socket.send(packet) {
            Ok(_) => Ok(()),
            // Nobody listening yet (ICMP port unreachable): like a full channel, a lost packet.
            Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => Err(TransportError::Full),
            Err(e) => Err(e.into()),
        }
    }
}

/// Receives datagrams on a bound address.
pub struct UdpReceiver {
    socket: UdpSocket,
    timeout: Option<Duration>,
    buf: Box<[u8]>,
    len: usize,
}

/// Largest UDP payload over IPv4.
const MAX_DATAGRAM: usize = 65_507;

impl UdpReceiver {
    /// Listen on `addr` ("127.0.0.1:0" picks a free port; see [`UdpReceiver::local_addr`]).
    pub fn bind(addr: impl ToSocketAddrs) -> io::Result<UdpReceiver> {
        Ok(UdpReceiver { socket: UdpSocket::bind(addr)?, timeout: None, buf: vec![0; MAX_DATAGRAM].into(), len: 0 })
    }

    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }
}

impl PacketReceiver for UdpReceiver {
    fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<&[u8]>, TransportError> {
        let timeout = timeout.max(Duration::from_micros(1)); // zero means "block forever" to the socket
        if self.timeout != Some(timeout) {
            self.socket.set_read_timeout(Some(timeout))?;
            self.timeout = Some(timeout);
        }
        match self.socket.recv(&mut self.buf) {
            Ok(n) => {
                self.len = n;
                Ok(Some(&self.buf[..self.len]))
            }
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => Ok(None),
            Err(e) => Err(e.into()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interaction::{decode, encode, ContactMessage, Limb, Message};

    fn strike(piece: &str, time_s: f32) -> Message {
        Message::Contact(ContactMessage {
            piece: piece.into(),
            time_s,
            speed_mps: 3.0,
            mass_kg: 0.03,
            x_m: 0.01,
            y_m: 0.0,
            impulse_ns: 0.0,
            hardness: 1.0,
            limb: Limb::RightHand,
        })
    }

    /// Send messages through a transport and decode what arrives.
    fn carry(tx: &mut dyn PacketSender, rx: &mut dyn PacketReceiver, msgs: &[Message]) -> Vec<Message> {
        let mut buf = Vec::new();
        for m in msgs {
            encode(m, &mut buf).unwrap();
            tx.send(&buf).unwrap();
        }
        let mut got = Vec::new();
        while got.len() < msgs.len() {
            let packet = rx.recv_timeout(Duration::from_secs(5)).unwrap().expect("a packet within 5 s");
            got.extend(decode(packet).unwrap());
        }
        got
    }

    fn messages() -> Vec<Message> {
        vec![strike("snare", 0.5), Message::HiHat { time_s: 0.75, openness: 0.2 }, strike("kick", 1.0)]
    }

    #[test]
    fn channel_carries_packets_in_order_and_recycles_buffers() {
        let (mut tx, mut rx) = channel(4);
        assert_eq!(carry(&mut tx, &mut rx, &messages()), messages());
        assert_eq!(carry(&mut tx, &mut rx, &messages()), messages());
        assert!(!tx.free.is_empty(), "read buffers come back to the sender");
        assert!(rx.recv_timeout(Duration::from_millis(1)).unwrap().is_none());
    }

    #[test]
    fn full_channel_refuses_and_closed_channel_is_reported() {
        let (mut tx, rx) = channel(1);
        tx.send(b"a").unwrap();
        assert!(matches!(tx.send(b"b"), Err(TransportError::Full)));
        drop(rx);
        assert!(matches!(tx.send(b"c"), Err(TransportError::Disconnected)));
    }

    #[test]
    fn udp_carries_real_datagrams_over_loopback() {
        let mut rx = UdpReceiver::bind("127.0.0.1:0").unwrap();
        let mut tx = UdpSender::connect(rx.local_addr().unwrap()).unwrap();
        assert_eq!(carry(&mut tx, &mut rx, &messages()), messages());
        assert!(rx.recv_timeout(Duration::from_millis(10)).unwrap().is_none(), "timeout gives None");
    }
}
