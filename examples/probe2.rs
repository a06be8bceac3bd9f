use drumsim::kit::{Kit, Piece};
use drumsim::sound::voice::Voice;
use drumsim::sound::*;
fn main() {
    let kit = Kit::builtin_default();
    for id in ["snare", "tom1", "crash", "kick"] {
        let p = Piece { wires: None, ..kit.piece(id).unwrap().clone() };
        let mut v = Voice::new(&p, 48000.0, 512);
        println!("{id}: E0={:e}", v.modal_energy_j());
        v.strike(&Strike { piece: 0, speed_mps: 6.0, mass_kg: 0.045, x_m: 0.0, y_m: -0.3 * p.radius_m, hardness: 1.0 });
        let c = v.last_contact;
        println!(
            "  after: E={:.4} reb={:.3} contact={:.3}ms span={:.3}ms J={:.4} given={:.4}",
            v.modal_energy_j(),
            c.rebound_mps,
            c.contact_s * 1e3,
            c.span_s * 1e3,
            c.impulse_ns,
            0.5 * 0.045 * 36.0
        );
        let mut acc = vec![[0.0f32; 8]; 512];
        let mut out = vec![0.0f32; 64];
        for i in 0..6 {
            v.render(&mut out, &mut acc);
            println!("  render {i}: E={:.4}", v.modal_energy_j());
        }
    }
}
