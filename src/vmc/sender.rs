//! The wall clock of VMC output and its UDP socket: frame `i` leaves at `start + i / rate`
//! (deadlines, so the rate never drifts); a sender that falls more than a frame behind skips
//! to the present and counts what it skipped. Failed sends (a receiver not started yet, a
//! network down) are counted, not fatal: a receiver may come and go.

use super::VmcError;
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

/// Deadlines at a fixed rate.
pub struct Pacer {
    start: Instant,
    rate_hz: f64,
    next: u64,
}

impl Pacer {
    pub fn new(rate_hz: f64) -> Pacer {
        Pacer { start: Instant::now(), rate_hz, next: 0 }
    }

    /// Seconds since the first frame's deadline.
    pub fn elapsed_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// When frame `i` is due.
    pub fn due(&self, i: u64) -> Instant {
        self.start + Duration::from_secs_f64(i as f64 / self.rate_hz)
    }

    /// Wait for the next frame's deadline and return its index and the number of frames
    /// skipped to catch up; none once `total` frames have gone.
    pub fn next_frame(&mut self, total: u64) -> Option<(u64, u64)> {
        if self.next >= total {
            return None;
        }
        let due = self.due(self.next);
        let now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
        }
        let now_frame = (self.elapsed_s() * self.rate_hz).floor() as u64;
        let mut skipped = 0;
        if now_frame > self.next + 1 {
            skipped = (now_frame - self.next).min(total.saturating_sub(self.next + 1));
            self.next += skipped;
        }
        let i = self.next;
        self.next += 1;
        Some((i, skipped))
    }
}

/// A UDP socket that sends to one receiver and counts.
pub struct Sender {
    socket: UdpSocket,
    target: SocketAddr,
    pub frames: u64,
    pub datagrams: u64,
    pub failed: u64,
    pub first_error: Option<String>,
}

impl Sender {
    pub fn new(target: SocketAddr) -> Result<Sender, VmcError> {
        let local: SocketAddr = if target.is_ipv4() { ([0, 0, 0, 0], 0).into() } else { ([0u16; 8], 0).into() };
        let socket = UdpSocket::bind(local).map_err(VmcError::Socket)?;
        Ok(Sender { socket, target, frames: 0, datagrams: 0, failed: 0, first_error: None })
    }

    /// Send one frame's datagrams.
    pub fn send_all(&mut self, datagrams: &[Vec<u8>]) {
        self.frames += 1;
        for d in datagrams {
            match self.socket.send_to(d, self.target) {
                Ok(_) => self.datagrams += 1,
                Err(e) => {
                    self.failed += 1;
                    self.first_error.get_or_insert_with(|| e.to_string());
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pacer_keeps_its_rate_and_catches_up() {
        let mut p = Pacer::new(100.0);
        let mut seen = Vec::new();
        let mut caught_up = 0;
        while let Some((i, skipped)) = p.next_frame(20) {
            if seen.last() == Some(&5) {
                caught_up = skipped;
            }
            seen.push(i);
            if i == 5 {
                std::thread::sleep(Duration::from_millis(60));
            }
        }
        // 20 frames at 100 Hz take 190 ms (the last leaves at 19 / 100 s): never early.
        assert!(p.elapsed_s() >= 0.19, "{}", p.elapsed_s());
        assert!(caught_up >= 4, "after a 60 ms stall the next frame skipped {caught_up}");
        assert_eq!(*seen.last().unwrap(), 19);
        assert!(seen.len() < 20, "the stall was not skipped: {seen:?}");
        assert!(seen.windows(2).all(|w| w[1] > w[0]));
    }
}
