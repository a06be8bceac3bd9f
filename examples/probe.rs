use drumsim::kit::{Kit, PieceKind};
use drumsim::sound::voice::Voice;
use drumsim::sound::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mut kit = Kit::builtin_default();
    if args.len() > 1 {
        for p in kit.pieces.iter_mut() {
            if p.kind == PieceKind::Membrane && p.id != "kick" {
                p.hertz_k = args[1].parse().unwrap();
            }
        }
    }
    for p in kit.pieces.iter() {
        for speed in [0.5f32, 2.0, 9.0] {
            let mut v = Voice::new(p, 48000.0, 512);
            let r = p.radius_m * if p.kind == PieceKind::Plate { 0.62 } else { 0.28 };
            let mass = if p.id == "kick" { 0.12 } else { 0.045 };
            v.strike(&Strike { piece: 0, speed_mps: speed, mass_kg: mass, x_m: 0.0, y_m: -r, hardness: 1.0 });
            let mut acc = vec![[0.0f32; 8]; 512];
            let mut out = vec![0.0f32; 512];
            let mut peak = 0.0f32;
            let mut e = 0.0f64;
            for _ in 0..94 {
                v.render(&mut out, &mut acc);
                for x in &out {
                    peak = peak.max(x.abs());
                    e += (*x as f64).powi(2);
                }
            }
            let c = v.last_contact;
            println!(
                "{:10} v={speed:4} peak={:7.1}dB rms={:6.1}dB contact={:.3}ms span={:.3}ms F={:.0}N reb={:.2}",
                p.id,
                20.0 * peak.log10(),
                10.0 * (e / 48000.0).log10(),
                c.contact_s * 1e3,
                c.span_s * 1e3,
                c.peak_force_n,
                c.rebound_mps
            );
        }
    }
}
