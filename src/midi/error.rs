//! Errors reading MIDI files. Each names the file and, where there is one, the place in it
//! (absolute tick and seconds) and what would have been allowed.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MidiError {
    #[error("{path}: cannot read: {source}")]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{path}: the file is {size} bytes; MIDI files over {limit} bytes (64 MiB) are refused")]
    TooLarge { path: PathBuf, size: u64, limit: u64 },
    #[error("{path}: the file is empty (0 bytes), not a MIDI file")]
    Empty { path: PathBuf },
    #[error("{path}: not a standard MIDI file: {message}")]
    NotMidi { path: PathBuf, message: String },
    /// The file ends before the data its header and chunk lengths announce.
    #[error("{path}: the file is truncated: {message}")]
    Truncated { path: PathBuf, message: String },
    #[error("{path}: not a usable MIDI file: {message}")]
    Parse { path: PathBuf, message: String },
    /// A tempo faster than 1000 BPM (0 included) is refused rather than clamped: it is a broken file.
    #[error(
        "{path}: tempo {us_per_beat} microseconds per beat at tick {tick} ({time_s:.3} s) is out of range; \
         allowed: {} ..= 16777215 (1000 BPM down to 3.6 BPM)",
        super::file::MIN_US_PER_BEAT
    )]
    Tempo { path: PathBuf, tick: u64, time_s: f64, us_per_beat: u32 },
    #[error("{path}: drum channel {channel} is not a MIDI channel; allowed: 1 ..= 16")]
    Channel { path: PathBuf, channel: u8 },
    #[error("{path}: {}", no_drums_message(*.channel, .found))]
    NoDrums {
        path: PathBuf,
        /// The channel asked for, 1-based.
        channel: u8,
        /// Channels (1-based, ascending) that do have note-ons, with their note-on counts.
        found: Vec<(u8, usize)>,
    },
}

fn no_drums_message(channel: u8, found: &[(u8, usize)]) -> String {
    if found.is_empty() {
        return format!("no note-ons on drum channel {channel}, nor on any other channel: the file holds no notes");
    }
    let list: Vec<String> =
        found.iter().map(|(ch, n)| format!("{ch} ({n} note{})", if *n == 1 { "" } else { "s" })).collect();
    let best = found.iter().max_by_key(|(_, n)| *n).map(|(ch, _)| *ch).unwrap_or(found[0].0);
    format!(
        "no note-ons on drum channel {channel}; notes are on channel{} {}; choose the drum channel with --channel {best}",
        if found.len() > 1 { "s" } else { "" },
        list.join(", ")
    )
}
