//! Standard MIDI files (types 0, 1 and 2) to drum events in seconds.
//!
//! - Type 0 and 1: all tracks are merged by tick; a tempo event in any track changes the tempo
//!   for every track (conventionally they sit in track 0). Events at the same tick keep file
//!   order (track 0 first, then each track in its own order).
//! - Type 2 (sequential patterns): the tracks are played one after the other, each starting
//!   where the previous one ended; a tempo set in one pattern carries on into the next.
//!   Ticks count from the start of the first pattern.
//! - Metrical timing uses the full tempo map (120 BPM until the first tempo event); SMPTE
//!   (timecode) timing ignores tempo events. 29 fps means 29.97 (drop-frame).
//! - A tempo of 0 or faster than 1000 BPM is an error ([`MidiError::Tempo`]), not clamped.
//! - midly parses leniently (a chunk cut short, a missing track or a bad event silently
//!   shortens the song), so the chunk layout and every event are checked here, and midly runs
//!   with its `strict` feature (a sysex or meta length past the track's end, a length of more
//!   than 4 bytes, a data byte with its top bit set are errors); an End-of-Track with events
//!   after it is an error too. A damaged file is an error naming the file, the track and the
//!   byte, never a shorter song.

use super::{DrumEvent, DrumEventKind, MidiError};
use midly::{MetaMessage, MidiMessage, TrackEventKind};
use std::io::Read;
use std::path::{Path, PathBuf};

/// Files larger than this are refused before they are read.
pub const MAX_FILE_BYTES: u64 = 64 * 1024 * 1024;
/// The fastest tempo accepted, in microseconds per beat (1000 BPM).
pub const MIN_US_PER_BEAT: u32 = 60_000;
/// MIDI's default tempo (120 BPM) until the first tempo event.
const DEFAULT_US_PER_BEAT: u32 = 500_000;
/// Controller number of the hi-hat pedal position.
const CC_HIHAT_PEDAL: u8 = 4;

/// What to read from a file.
#[derive(Debug, Clone)]
pub struct ReadOptions {
    /// Drum channel, 1..=16.
    pub channel: u8,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions { channel: 10 }
    }
}

/// A drum performance read from a file: drum-channel events in time order.
#[derive(Debug, Clone)]
pub struct Performance {
    pub path: PathBuf,
    pub events: Vec<DrumEvent>,
    /// End of the last track (or the last event, if later), seconds.
    pub duration_s: f64,
    /// End of the last note on the drum channel (its note-off, else its note-on), seconds.
    /// Files may run on long after it: a Groove MIDI take has 276 s of hi-hat pedal (CC4) only.
    pub notes_end_s: f64,
    /// The drum channel that was read, 1..=16.
    pub channel: u8,
}

impl Performance {
    /// A fingerprint of the notes (time to the microsecond, note, velocity of every note-on),
    /// 16 hex digits: a render writes it into SONG.contacts.json so that `eval` knows the
    /// outputs it measures are this song's.
    pub fn notes_fingerprint(&self) -> String {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h = (h ^ b as u64).wrapping_mul(0x100_0000_01b3);
            }
        };
        for e in &self.events {
            if let DrumEventKind::NoteOn { note, velocity } = e.kind {
                eat(&((e.time_s * 1e6).round() as i64).to_le_bytes());
                eat(&[note, velocity]);
            }
        }
        format!("{h:016x}")
    }
}

/// Read a standard MIDI file; only events of `opts.channel` are kept.
pub fn read_file(path: &Path, opts: &ReadOptions) -> Result<Performance, MidiError> {
    check_channel(path, opts.channel)?;
    let bytes = read_bytes(path)?;
    parse_bytes(&bytes, path, opts)
}

/// Parse the bytes of a standard MIDI file; `path` is only used in messages.
pub fn parse_bytes(bytes: &[u8], path: &Path, opts: &ReadOptions) -> Result<Performance, MidiError> {
    check_channel(path, opts.channel)?;
    if bytes.is_empty() {
        return Err(MidiError::Empty { path: path.to_path_buf() });
    }
    let smf = split_chunks(bytes, path)?;
    let mut reader = TrackReader { path, channel: opts.channel - 1, items: Vec::new(), note_ons: [0; 16] };
    let mut end_ticks = Vec::with_capacity(smf.tracks.len());
    let mut offset = 0u64;
    for (i, data) in smf.tracks.iter().enumerate() {
        let end = reader.read_track(i, data, offset)?;
        end_ticks.push(end);
        if smf.format == 2 {
            offset = end;
        }
    }
    if reader.note_ons[usize::from(reader.channel)] == 0 {
        let found = (1u8..=16).zip(reader.note_ons).filter(|(_, n)| *n > 0).collect();
        return Err(MidiError::NoDrums { path: path.to_path_buf(), channel: opts.channel, found });
    }
    let end_tick = end_ticks.into_iter().max().unwrap_or(0);
    let mut items = reader.items;
    items.sort_by_key(|it| it.tick); // stable: file order within a tick
    let mut clock = Clock::new(smf.division);
    let mut events = Vec::with_capacity(items.len());
    for it in items {
        match it.kind {
            Item::Tempo(us) => {
                if clock.set_tempo(it.tick, us).is_err() {
                    let time_s = clock.seconds(it.tick);
                    return Err(MidiError::Tempo { path: path.to_path_buf(), tick: it.tick, time_s, us_per_beat: us });
                }
            }
            Item::Drum(kind) => events.push(DrumEvent { time_s: clock.seconds(it.tick), tick: it.tick, kind }),
        }
    }
    let last = events.last().map_or(0.0, |e| e.time_s);
    let duration_s = clock.seconds(end_tick).max(last);
    let is_note = |e: &&DrumEvent| matches!(e.kind, DrumEventKind::NoteOn { .. } | DrumEventKind::NoteOff { .. });
    let notes_end_s = events.iter().rev().find(is_note).map_or(0.0, |e| e.time_s);
    Ok(Performance { path: path.to_path_buf(), events, duration_s, notes_end_s, channel: opts.channel })
}

fn check_channel(path: &Path, channel: u8) -> Result<(), MidiError> {
    if (1..=16).contains(&channel) {
        Ok(())
    } else {
        Err(MidiError::Channel { path: path.to_path_buf(), channel })
    }
}

/// The whole file, refusing one over [`MAX_FILE_BYTES`] before reading it.
fn read_bytes(path: &Path) -> Result<Vec<u8>, MidiError> {
    let read_err = |source| MidiError::Read { path: path.to_path_buf(), source };
    let file = std::fs::File::open(path).map_err(read_err)?;
    let meta = file.metadata().map_err(read_err)?;
    if meta.is_dir() {
        let source = std::io::Error::other("it is a directory");
        return Err(MidiError::Read { path: path.to_path_buf(), source });
    }
    let too_large = |size| MidiError::TooLarge { path: path.to_path_buf(), size, limit: MAX_FILE_BYTES };
    if meta.len() > MAX_FILE_BYTES {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(MAX_FILE_BYTES + 1).read_to_end(&mut bytes).map_err(read_err)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(too_large(bytes.len() as u64)); // grew while we read it
    }
    Ok(bytes)
}

/// How ticks become time.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Division {
    Metrical { ticks_per_beat: u16 },
    Timecode { ticks_per_s: f64 },
}

/// The checked chunk layout of a file.
struct Chunks<'a> {
    format: u16,
    division: Division,
    tracks: Vec<&'a [u8]>,
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn split_chunks<'a>(bytes: &'a [u8], path: &Path) -> Result<Chunks<'a>, MidiError> {
    let truncated = |message: String| MidiError::Truncated { path: path.to_path_buf(), message };
    let parse = |message: String| MidiError::Parse { path: path.to_path_buf(), message };
    if bytes.starts_with(b"RIFF") {
        let message = "it is a RIFF MIDI (.rmi) file; extract the standard MIDI data inside it".into();
        return Err(MidiError::NotMidi { path: path.to_path_buf(), message });
    }
    if bytes.len() < 4 && b"MThd".starts_with(bytes) {
        return Err(truncated(format!("it ends after {} bytes, inside the header", bytes.len())));
    }
    if !bytes.starts_with(b"MThd") {
        let head: Vec<String> = bytes.iter().take(8).map(|b| format!("{b:02x}")).collect();
        let message = format!("it does not start with \"MThd\" (its first bytes are {})", head.join(" "));
        return Err(MidiError::NotMidi { path: path.to_path_buf(), message });
    }
    if bytes.len() < 14 {
        return Err(truncated(format!("it ends after {} bytes, inside the 14-byte header", bytes.len())));
    }
    let header_len = u32_at(bytes, 4) as usize;
    if header_len < 6 {
        return Err(parse(format!("the header chunk is {header_len} bytes long; it must be at least 6")));
    }
    let format = u16::from_be_bytes([bytes[8], bytes[9]]);
    let declared = usize::from(u16::from_be_bytes([bytes[10], bytes[11]]));
    let division = match (bytes[12], bytes[13]) {
        (hi, lo) if hi & 0x80 == 0 => match u16::from_be_bytes([hi, lo]) {
            0 => return Err(parse("the header gives 0 ticks per beat; allowed: 1 ..= 32767".into())),
            ticks_per_beat => Division::Metrical { ticks_per_beat },
        },
        (hi, lo) => {
            let fps = match -(hi as i8) {
                24 => 24.0,
                25 => 25.0,
                29 => 30_000.0 / 1001.0,
                30 => 30.0,
                other => {
                    let m = format!("SMPTE timing at {other} frames per second; allowed: 24, 25, 29 (29.97), 30");
                    return Err(parse(m));
                }
            };
            if lo == 0 {
                return Err(parse("SMPTE timing with 0 ticks per frame; allowed: 1 ..= 255".into()));
            }
            Division::Timecode { ticks_per_s: fps * f64::from(lo) }
        }
    };
    if format > 2 {
        return Err(parse(format!("the header gives format {format}; allowed: 0, 1, 2")));
    }
    let mut tracks = Vec::with_capacity(declared);
    let mut pos = 8usize.saturating_add(header_len);
    if pos > bytes.len() {
        return Err(truncated(format!("the header chunk announces {header_len} bytes; the file ends before")));
    }
    while pos < bytes.len() {
        let rest = bytes.len() - pos;
        let id = &bytes[pos..pos + rest.min(4)];
        let complete = tracks.len() >= declared;
        if complete && (rest < 8 || !id.iter().all(u8::is_ascii_alphanumeric)) {
            break; // padding or junk after all the declared tracks: harmless
        }
        if rest < 8 {
            return Err(truncated(format!(
                "it ends at byte {} inside the header of chunk {} (track {} of {declared})",
                bytes.len(),
                tracks.len() + 1,
                tracks.len() + 1
            )));
        }
        let len = u32_at(bytes, pos + 4) as usize;
        if len > rest - 8 {
            return Err(truncated(format!(
                "track {} (chunk at byte {pos}) announces {len} bytes but only {} remain",
                tracks.len() + 1,
                rest - 8
            )));
        }
        if id == b"MTrk" {
            tracks.push(&bytes[pos + 8..pos + 8 + len]);
        } // other chunk types are skipped, as the standard asks
        pos += 8 + len;
    }
    if tracks.len() < declared {
        return Err(truncated(format!("the header announces {declared} tracks but the file holds {}", tracks.len())));
    }
    Ok(Chunks { format, division, tracks })
}

/// Something that matters for the drum channel, at an absolute tick.
struct Timed {
    tick: u64,
    kind: Item,
}

enum Item {
    Tempo(u32),
    Drum(DrumEventKind),
}

struct TrackReader<'p> {
    path: &'p Path,
    /// 0-based.
    channel: u8,
    items: Vec<Timed>,
    /// Note-ons with velocity > 0, per 0-based channel.
    note_ons: [usize; 16],
}

impl TrackReader<'_> {
    /// Read one track; returns its end tick (its end-of-track event, else its last event).
    fn read_track(&mut self, index: usize, data: &[u8], offset: u64) -> Result<u64, MidiError> {
        let mut iter = midly::EventIter::new(data);
        let mut tick = offset;
        loop {
            let unread = iter.unread().len();
            let event = match iter.next() {
                None if unread == 0 => break,
                // Lenient midly ends the track silently at a bad event; that is an error here.
                None | Some(Err(_)) => {
                    let message = format!(
                        "track {}: malformed event at byte {} of {} in the track, after tick {tick}",
                        index + 1,
                        data.len() - unread,
                        data.len()
                    );
                    return Err(MidiError::Parse { path: self.path.to_path_buf(), message });
                }
                Some(Ok(event)) => event,
            };
            tick += u64::from(event.delta.as_int());
            let drum = match event.kind {
                TrackEventKind::Meta(MetaMessage::EndOfTrack) => {
                    let after = iter.unread().len();
                    if after > 0 {
                        let message = format!(
                            "track {}: End-of-Track at tick {tick}, byte {} of {} in the track, with {after} bytes \
                             of events after it",
                            index + 1,
                            data.len() - after,
                            data.len()
                        );
                        return Err(MidiError::Parse { path: self.path.to_path_buf(), message });
                    }
                    break;
                }
                TrackEventKind::Meta(MetaMessage::Tempo(us)) => {
                    self.items.push(Timed { tick, kind: Item::Tempo(us.as_int()) });
                    continue;
                }
                TrackEventKind::Midi { channel, message } => {
                    let key_on = matches!(message, MidiMessage::NoteOn { vel, .. } if vel > 0);
                    if key_on {
                        self.note_ons[usize::from(channel.as_int())] += 1;
                    }
                    if channel.as_int() != self.channel {
                        continue;
                    }
                    match message {
                        MidiMessage::NoteOn { key, vel } if vel == 0 => DrumEventKind::NoteOff { note: key.as_int() },
                        MidiMessage::NoteOn { key, vel } => {
                            DrumEventKind::NoteOn { note: key.as_int(), velocity: vel.as_int() }
                        }
                        MidiMessage::NoteOff { key, .. } => DrumEventKind::NoteOff { note: key.as_int() },
                        MidiMessage::Controller { controller, value } if controller == CC_HIHAT_PEDAL => {
                            DrumEventKind::HiHatPedal { value: value.as_int() }
                        }
                        MidiMessage::Aftertouch { key, vel } => {
                            DrumEventKind::Aftertouch { note: key.as_int(), pressure: vel.as_int() }
                        }
                        _ => continue,
                    }
                }
                _ => continue,
            };
            self.items.push(Timed { tick, kind: Item::Drum(drum) });
        }
        Ok(tick)
    }
}

/// Ticks to seconds through the tempo map.
struct Clock {
    division: Division,
    /// Start of the current tempo segment.
    seg_tick: u64,
    seg_s: f64,
    us_per_beat: u32,
}

impl Clock {
    fn new(division: Division) -> Clock {
        Clock { division, seg_tick: 0, seg_s: 0.0, us_per_beat: DEFAULT_US_PER_BEAT }
    }

    /// Seconds at `tick`, which must not be before the last tempo change.
    fn seconds(&self, tick: u64) -> f64 {
        match self.division {
            Division::Timecode { ticks_per_s } => tick as f64 / ticks_per_s,
            Division::Metrical { ticks_per_beat } => {
                let beats = tick.saturating_sub(self.seg_tick) as f64 / f64::from(ticks_per_beat);
                self.seg_s + beats * f64::from(self.us_per_beat) * 1e-6
            }
        }
    }

    /// A tempo event; Err(()) when it is out of range (under SMPTE timing tempo is ignored).
    fn set_tempo(&mut self, tick: u64, us_per_beat: u32) -> Result<(), ()> {
        if matches!(self.division, Division::Timecode { .. }) {
            return Ok(());
        }
        if us_per_beat < MIN_US_PER_BEAT {
            return Err(());
        }
        self.seg_s = self.seconds(tick);
        self.seg_tick = tick;
        self.us_per_beat = us_per_beat;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Type 0, 96 ticks per beat, one track of `events` (delta-time bytes included) and end-of-track.
    fn smf(division: [u8; 2], events: &[u8]) -> Vec<u8> {
        let mut b = b"MThd\0\0\0\x06\0\0\0\x01".to_vec();
        b.extend(division);
        b.extend(b"MTrk");
        b.extend((events.len() as u32 + 4).to_be_bytes());
        b.extend(events);
        b.extend([0x00, 0xFF, 0x2F, 0x00]);
        b
    }

    fn parse(bytes: &[u8]) -> Result<Performance, MidiError> {
        parse_bytes(bytes, Path::new("t.mid"), &ReadOptions::default())
    }

    const KICK: [u8; 4] = [0x00, 0x99, 36, 100];

    #[test]
    fn clock_integrates_the_tempo_map() {
        let mut c = Clock::new(Division::Metrical { ticks_per_beat: 100 });
        assert_eq!(c.seconds(100), 0.5);
        c.set_tempo(200, 1_000_000).unwrap();
        assert_eq!(c.seconds(250), 1.5);
        c.set_tempo(300, MIN_US_PER_BEAT).unwrap();
        assert!((c.seconds(400) - 2.06).abs() < 1e-12);
        assert!(c.set_tempo(400, MIN_US_PER_BEAT - 1).is_err());
    }

    #[test]
    fn tempo_of_1000_bpm_is_accepted_and_faster_refused() {
        let fast = |us: u32| {
            let t = us.to_be_bytes();
            let mut ev = vec![0x00, 0xFF, 0x51, 0x03, t[1], t[2], t[3]];
            ev.extend([0x60, 0x99, 36, 100]);
            parse(&smf([0, 96], &ev))
        };
        let perf = fast(MIN_US_PER_BEAT).unwrap();
        assert!((perf.events[0].time_s - 0.06).abs() < 1e-12);
        let msg = fast(MIN_US_PER_BEAT - 1).unwrap_err().to_string();
        assert!(msg.contains("59999") && msg.contains("60000 ..= 16777215"), "{msg}");
    }

    #[test]
    fn bad_timing_fields_are_errors() {
        let msg = parse(&smf([0, 0], &KICK)).unwrap_err().to_string();
        assert!(msg.contains("0 ticks per beat"), "{msg}");
        let msg = parse(&smf([(-23i8) as u8, 10], &KICK)).unwrap_err().to_string();
        assert!(msg.contains("23 frames per second") && msg.contains("24, 25, 29 (29.97), 30"), "{msg}");
        let msg = parse(&smf([(-25i8) as u8, 0], &KICK)).unwrap_err().to_string();
        assert!(msg.contains("0 ticks per frame"), "{msg}");
        let mut bad_format = smf([0, 96], &KICK);
        bad_format[9] = 3;
        assert!(parse(&bad_format).unwrap_err().to_string().contains("format 3"));
    }

    #[test]
    fn padding_after_the_tracks_and_unknown_chunks_are_skipped() {
        let mut b = smf([0, 96], &KICK);
        let track = b.split_off(14);
        b.extend(b"XFIH\0\0\0\x02ab"); // a chunk type this reader does not know
        b.extend(track);
        b.extend([0, 0, 0]); // padding
        assert_eq!(parse(&b).unwrap().events.len(), 1);
    }

    #[test]
    fn channel_out_of_range_is_an_error() {
        let opts = ReadOptions { channel: 0 };
        let err = parse_bytes(&smf([0, 96], &KICK), Path::new("t.mid"), &opts).unwrap_err();
        assert!(matches!(err, MidiError::Channel { channel: 0, .. }), "{err:?}");
    }

    #[test]
    fn rmid_is_named() {
        let msg = parse(b"RIFF\0\0\0\0RMIDdata").unwrap_err().to_string();
        assert!(msg.contains("RIFF MIDI"), "{msg}");
    }
}
