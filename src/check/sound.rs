//! The sound engine under a barrage: every piece struck hundreds of times a second at up to
//! half again the kit's hardest speed, all at once now and then, cymbals choked, the hi-hat
//! pedal moving every 10 ms. Nothing may come out non-finite or above full scale.

use super::{Check, Measure};
use crate::interaction::{ContactMessage, Limb, Message};
use crate::kit::{Kit, PieceKind};
use crate::rng::Rng;
use crate::sound::SoundEvent;

/// The check's name.
pub const NAME: &str = "sound/barrage";
const SECONDS: f64 = 10.0;
const STRIKES_PER_S: f64 = 400.0;

fn contact(kit: &Kit, piece: usize, time_s: f64, rng: &mut Rng) -> Message {
    let p = &kit.pieces[piece];
    let r = p.radius_m * 0.95 * rng.unit();
    let a = std::f32::consts::TAU * rng.unit();
    let feet = p.id == "kick";
    Message::Contact(ContactMessage {
        piece: p.id.clone(),
        time_s: time_s as f32,
        speed_mps: kit.strike.speed_max_mps * 1.5 * rng.unit(),
        mass_kg: if feet { kit.strike.beater_mass_kg } else { kit.strike.stick_mass_kg * (0.5 + rng.unit()) },
        x_m: r * a.cos(),
        y_m: r * a.sin(),
        impulse_ns: 0.0,
        hardness: 1.0,
        limb: if feet { Limb::RightFoot } else { Limb::RightHand },
    })
}

/// The barrage's messages, in time order.
fn messages(kit: &Kit) -> Vec<Message> {
    let mut rng = Rng::new(7);
    let mut out = Vec::new();
    let n = (SECONDS * STRIKES_PER_S) as usize;
    for k in 0..n {
        let t = k as f64 / STRIKES_PER_S;
        let piece = (rng.unit() * kit.pieces.len() as f32) as usize % kit.pieces.len();
        out.push(contact(kit, piece, t, &mut rng));
    }
    // Every piece at one instant, eight times over, every two seconds.
    for burst in 0..(SECONDS as usize / 2) {
        let t = 1.0 + 2.0 * burst as f64;
        for _ in 0..8 {
            for piece in 0..kit.pieces.len() {
                out.push(contact(kit, piece, t, &mut rng));
            }
        }
    }
    for k in 0..(SECONDS * 100.0) as usize {
        out.push(Message::HiHat { time_s: k as f32 / 100.0, openness: rng.unit() });
    }
    for k in 0..(SECONDS * 4.0) as usize {
        for p in kit.pieces.iter().filter(|p| p.kind == PieceKind::Plate) {
            out.push(Message::Choke { piece: p.id.clone(), time_s: 0.125 + k as f32 * 0.25 });
        }
    }
    out.sort_by(|a, b| a.time_s().total_cmp(&b.time_s()));
    out
}

/// Render the barrage and measure it.
pub fn barrage(kit: &Kit) -> Check {
    let name = NAME.to_string();
    let events: Result<Vec<SoundEvent>, _> =
        messages(kit).iter().map(|m| SoundEvent::from_message(m, kit, crate::render::SAMPLE_RATE_HZ as f32)).collect();
    let events = match events {
        Ok(e) => e,
        Err(e) => return Check::failed(name, e.to_string()),
    };
    let mut peak = 0.0f32;
    let mut non_finite_out = 0u64;
    let result = crate::render::render_events(
        kit,
        &events,
        SECONDS,
        |l, r| {
            for x in l.iter().chain(r) {
                if x.is_finite() {
                    peak = peak.max(x.abs());
                } else {
                    non_finite_out += 1;
                }
            }
            Ok(())
        },
        |_| {},
    );
    match result {
        Ok((samples, silenced)) => Check::new(
            name,
            samples as f64 / crate::render::SAMPLE_RATE_HZ as f64,
            vec![
                Measure::equals("non-finite samples", (silenced + non_finite_out) as f64, 0.0, ""),
                Measure::below("peak", peak as f64, 1.0 + 1e-6, "full scale"),
                Measure::at_least("strikes", events.len() as f64, SECONDS * STRIKES_PER_S, ""),
            ],
        ),
        Err(e) => Check::failed(name, e.to_string()),
    }
}
