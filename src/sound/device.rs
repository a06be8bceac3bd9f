//! Audio devices (cpal): hosts and their outputs, choosing a device and a stream config, and
//! the running output stream that drives the real-time [`Renderer`] from the host's callback.

use super::audio_clock::AudioClock;
use super::denormals::with_flush_to_zero;
use super::output::{OutputSettings, OutputStats, Renderer, TimedEvent};
use super::{Engine, EngineSettings};
use crate::kit::Kit;
use cpal::traits::{DeviceTrait, HostTrait, StreamTrait};
use cpal::{BufferSize, HostId, SampleFormat, StreamConfig, SupportedBufferSize};
use crossbeam_channel::Receiver;
use rtrb::Consumer;
use std::sync::atomic::Ordering::Relaxed;
use std::sync::Arc;
use std::time::{Duration, Instant};
/// An audio output device of some host.
#[derive(Clone)]
pub struct OutputDevice {
    pub host: HostId,
    pub device: cpal::Device,
    /// "HOST: NAME [ID]", what `--audio` is matched against.
    pub label: String,
    pub is_default: bool,
}

/// Hosts in the order `live` prefers them: JACK first where compiled in, then the default.
pub fn hosts() -> Vec<HostId> {
    let default = cpal::default_host().id();
    let jack = |h: &HostId| *h != default && h.name().eq_ignore_ascii_case("jack");
    let mut ids: Vec<HostId> = cpal::available_hosts().into_iter().filter(jack).collect();
    ids.push(default);
    ids
}

/// The output devices of one host, its default first.
pub fn host_outputs(id: HostId) -> Result<Vec<OutputDevice>, cpal::Error> {
    let host = cpal::host_from_id(id)?;
    let default = host.default_output_device();
    let default_id = default.as_ref().and_then(|d| d.id().ok());
    let describe = |device: cpal::Device| {
        let description = device.description().ok();
        // JACK lists its input device among the outputs: ask each device its direction.
        if description.as_ref().is_some_and(|d| d.direction() == cpal::DeviceDirection::Input) {
            return None;
        }
        let name = description.map_or_else(|| "?".to_string(), |d| d.name().to_string());
        let dev_id = device.id().ok();
        let is_default = dev_id.is_some() && dev_id == default_id;
        let id_text = dev_id.map(|i| i.to_string()).unwrap_or_default();
        Some(OutputDevice { host: id, device, label: format!("{}: {name} [{id_text}]", id.name()), is_default })
    };
    let mut out: Vec<OutputDevice> = host.output_devices()?.filter_map(describe).collect();
    if !out.iter().any(|d| d.is_default) {
        out.extend(default.and_then(describe)); // a default the enumeration left out
    }
    out.sort_by_key(|d| !d.is_default);
    Ok(out)
}

/// The first device (hosts in [`hosts`] order, defaults first) whose label contains `wanted`,
/// ignoring case; no `wanted`: the first host's default. `Err` lists what was there.
pub fn find_output(wanted: Option<&str>) -> Result<OutputDevice, Vec<String>> {
    let mut seen = Vec::new();
    for id in hosts() {
        let devices = host_outputs(id).unwrap_or_default();
        let hit = match wanted {
            None => devices.iter().position(|d| d.is_default),
            Some(w) => devices.iter().position(|d| d.label.to_lowercase().contains(&w.to_lowercase())),
        };
        if let Some(i) = hit {
            return Ok(devices[i].clone());
        }
        seen.extend(devices.into_iter().map(|d| d.label));
    }
    Err(seen)
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    #[error("audio device {device}: no 32-bit float output configuration")]
    NoFloatConfig { device: String },
    #[error("audio device {device}: --stems needs {channels} output channels (the mix and one per kit piece); it offers at most {offered}")]
    NoStemChannels { device: String, channels: u16, offered: u16 },
    #[error("audio device {device}: {source}")]
    Device { device: String, source: cpal::Error },
}

/// The device's f32 configuration: `channels` if given (else its default channel count),
/// `sample_rate_hz` if it can, else its default rate; `buffer_frames` if the device lets us
/// choose.
pub fn choose_config(
    out: &OutputDevice,
    settings: &OutputSettings,
    channels: Option<u16>,
) -> Result<StreamConfig, OutputError> {
    let err = |source| OutputError::Device { device: out.label.clone(), source };
    let default = out.device.default_output_config().map_err(err)?;
    let ranges: Vec<_> = out
        .device
        .supported_output_configs()
        .map_err(err)?
        .filter(|r| r.sample_format() == SampleFormat::F32)
        .collect();
    if let Some(c) = channels {
        offers_channels(&out.label, ranges.iter().map(|r| r.channels()), c)?;
    }
    let ranges: Vec<_> = ranges.into_iter().filter(|r| channels.is_none_or(|c| r.channels() == c)).collect();
    let by_channels = |c| ranges.iter().filter(move |r| r.channels() == c);
    let chosen = [settings.sample_rate_hz, default.sample_rate()]
        .into_iter()
        .find_map(|rate| by_channels(default.channels()).chain(&ranges).find_map(|r| r.try_with_sample_rate(rate)))
        .or_else(|| ranges.first().map(|r| r.with_max_sample_rate()))
        .ok_or_else(|| OutputError::NoFloatConfig { device: out.label.clone() })?;
    let buffer_size = match chosen.buffer_size() {
        SupportedBufferSize::Range { min, max } if (*min..=*max).contains(&settings.buffer_frames) => {
            BufferSize::Fixed(settings.buffer_frames)
        }
        _ => BufferSize::Default,
    };
    Ok(StreamConfig { channels: chosen.channels(), sample_rate: chosen.sample_rate(), buffer_size })
}

/// `Ok` if one of the device's configurations (`offered`, channel counts) has `channels`.
fn offers_channels(device: &str, offered: impl Iterator<Item = u16> + Clone, channels: u16) -> Result<(), OutputError> {
    if offered.clone().any(|c| c == channels) {
        return Ok(());
    }
    let offered = offered.max().unwrap_or(0);
    Err(OutputError::NoStemChannels { device: device.to_string(), channels, offered })
}

/// Which output channel carries which piece with `--stems`, for the user.
pub fn stem_channels(kit: &Kit) -> String {
    let pieces: Vec<String> = kit.pieces.iter().enumerate().map(|(k, p)| format!("{} {}", k + 3, p.id)).collect();
    format!("stems: channels 1-2 the mix, then {}", pieces.join(", "))
}

/// A running output stream.
pub struct AudioOutput {
    _stream: cpal::Stream,
    pub label: String,
    pub sample_rate_hz: u32,
    pub channels: u16,
    /// Frames per callback, where the host says.
    pub buffer_frames: Option<u32>,
    /// The engine's own delay (its limiter's look-ahead), samples.
    pub engine_latency_samples: usize,
    pub stats: Arc<OutputStats>,
    errors: Receiver<cpal::Error>,
}

impl AudioOutput {
    /// Build the engine and start the stream; the callback takes its events from `events`.
    pub fn start(
        out: &OutputDevice,
        kit: &Kit,
        settings: &OutputSettings,
        events: Consumer<TimedEvent>,
    ) -> Result<AudioOutput, OutputError> {
        let channels = settings.stems.then(|| 2 + kit.pieces.len() as u16);
        let config = choose_config(out, settings, channels)?;
        let fs = config.sample_rate;
        let engine_settings = EngineSettings {
            sample_rate_hz: fs as f32,
            max_block: settings.max_block,
            event_capacity: settings.event_capacity,
        };
        let engine = match settings.stems {
            true => Engine::new(kit, engine_settings).with_stems(),
            false => Engine::new(kit, engine_settings),
        };
        let engine_latency_samples = engine.latency_samples();
        let stats = Arc::new(OutputStats::default());
        let mut renderer = Renderer::new(engine, events, config.channels.into(), fs.into(), settings, stats.clone());
        let (cb_stats, err_stats) = (stats.clone(), stats.clone());
        let (err_tx, errors) = crossbeam_channel::bounded(16);
        // Each block placed on the stream's own clock, not at the moment its callback woke.
        let mut clock = AudioClock::new(fs.into());
        let channels = usize::from(config.channels).max(1);
        let data = move |data: &mut [f32], info: &cpal::OutputCallbackInfo| {
            let entered = Instant::now();
            clock.xrun_seen(cb_stats.xruns.load(Relaxed));
            let ts = info.timestamp();
            // From callback to playback, s: the host's word on this callback's lateness (less
            // is later), up to a constant (`audio_clock`), and the output's latency.
            let ahead = (ts.playback.as_nanos() as f64 - ts.callback.as_nanos() as f64) * 1e-9;
            let block = clock.block_told(entered, data.len() / channels, -ahead);
            cb_stats.clock_relocks.store(clock.relocks, Relaxed);
            cb_stats.clock_steps.store(clock.steps, Relaxed);
            with_flush_to_zero(|| renderer.render(data, block));
            cb_stats.output_latency_us.store((ahead.max(0.0) * 1e6) as u64, Relaxed);
            let budget = Duration::from_secs_f64(data.len() as f64 / (f64::from(config.channels) * f64::from(fs)));
            if entered.elapsed() > budget {
                cb_stats.overloads.fetch_add(1, Relaxed);
            }
        };
        let error = move |e: cpal::Error| {
            if e.kind() == cpal::ErrorKind::Xrun {
                err_stats.xruns.fetch_add(1, Relaxed);
            } else {
                let _ = err_tx.try_send(e);
            }
        };
        let err = |source| OutputError::Device { device: out.label.clone(), source };
        let stream = out.device.build_output_stream(config, data, error, None).map_err(err)?;
        stream.play().map_err(err)?;
        Ok(AudioOutput {
            buffer_frames: stream.buffer_size().ok(),
            _stream: stream,
            label: out.label.clone(),
            sample_rate_hz: fs,
            channels: config.channels,
            engine_latency_samples,
            stats,
            errors,
        })
    }

    /// A stream error the host reported since the last call (xruns are only counted).
    pub fn error(&self) -> Option<cpal::Error> {
        self.errors.try_recv().ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_device_without_room_for_the_stems_is_refused_naming_what_it_offers() {
        assert!(offers_channels("JACK", 1..=64, 13).is_ok());
        let err = offers_channels("ALSA: hw", [1, 2].into_iter(), 13).unwrap_err();
        assert_eq!(
            err.to_string(),
            "audio device ALSA: hw: --stems needs 13 output channels (the mix and one per kit piece); it offers at most 2"
        );
    }
}
