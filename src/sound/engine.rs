//! The sound engine: one modal resonator per kit piece, events applied sample-accurately.

use super::SoundEvent;
use crate::kit::Kit;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EngineSettings {
    pub sample_rate_hz: f32,
    /// Largest block `process` works on at once (longer buffers are split).
    pub max_block: usize,
    /// Capacity of the pending-event queue.
    pub event_capacity: usize,
}

impl Default for EngineSettings {
    fn default() -> Self {
        EngineSettings { sample_rate_hz: 48_000.0, max_block: 512, event_capacity: 1024 }
    }
}

pub struct Engine {
    time: u64,
}

impl Engine {
    pub fn new(_kit: &Kit, _settings: EngineSettings) -> Engine {
        Engine { time: 0 }
    }
    /// The sample index the next `process` call starts at.
    pub fn sample_time(&self) -> u64 {
        self.time
    }
    /// Queue an event; false if the queue is full (the event is dropped and counted).
    pub fn push(&mut self, _ev: SoundEvent) -> bool {
        true
    }
    /// Render `left.len()` samples (left and right have equal length).
    pub fn process(&mut self, left: &mut [f32], right: &mut [f32]) {
        left.fill(0.0);
        right.fill(0.0);
        self.time += left.len() as u64;
    }
    /// Samples by which the output trails the events (the limiter's look-ahead).
    pub fn latency_samples(&self) -> usize {
        0
    }
}
