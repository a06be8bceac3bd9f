//! `SONG.bvh`: the rig's hierarchy and one line of channels per frame (Biovision BVH).
//!
//! Units are centimetres; axes Y-up with the drummer facing +Z (see `export`). The root
//! (hips) has six channels, `Xposition Yposition Zposition Zrotation Xrotation Yrotation`,
//! every other joint three, `Zrotation Xrotation Yrotation`, in degrees: a joint's rotation
//! is `Rz * Rx * Ry` (Z applied outermost). All 57 bones are joints; leaves carry an
//! `End Site` at the bone's tip. The root's OFFSET is zero and its position channels hold
//! its absolute position; the rest pose is the rig's (every rotation zero).

use super::{write_file, write_one, y_up, y_up_rot, Baked, ExportError};
use crate::motion::rig::Rig;
use crate::motion::track::Motion;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::io::Write;
use std::path::Path;

const CM: f32 = 100.0;

/// Write the BVH of `motion` through `rig` to `path`.
pub fn write(motion: &Motion, rig: &Rig, path: &Path) -> Result<(), ExportError> {
    let baked = Baked::new(motion, rig)?;
    write_one(path, |partial| write_baked(&baked, partial))
}

/// Write already-solved motion to `path` as it is (a partial name of an output set).
pub fn write_baked(baked: &Baked, path: &Path) -> Result<(), ExportError> {
    let rig = baked.rig;
    write_file(path, |w: &mut dyn Write| {
        writeln!(w, "HIERARCHY")?;
        write_joint(w, rig, &baked.names, 0, 0)?;
        writeln!(w, "MOTION")?;
        writeln!(w, "Frames: {}", baked.poses.len())?;
        writeln!(w, "Frame Time: {:.8}", 1.0 / baked.motion.fps)?;
        let mut line = String::new();
        for pose in &baked.poses {
            line.clear();
            let root = y_up(pose.root * CM);
            for x in root {
                line.push_str(&format!("{} ", finite(x, 4)));
            }
            for q in &pose.local {
                let [z, x, y] = euler_zxy_deg(q);
                line.push_str(&format!("{} {} {} ", finite(z, 4), finite(x, 4), finite(y, 4)));
            }
            writeln!(w, "{}", line.trim_end())?;
        }
        Ok(())
    })
}

/// A number with `digits` decimals, 0 when not finite (BVH has no NaN).
fn finite(x: f32, digits: usize) -> String {
    let x = if x.is_finite() { x } else { 0.0 };
    let s = format!("{x:.digits$}");
    // Trim "-0.0000" to "0.0000" so that the text is stable.
    if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

fn write_joint(w: &mut dyn Write, rig: &Rig, names: &[String], bone: usize, depth: usize) -> std::io::Result<()> {
    let pad = "  ".repeat(depth);
    let b = &rig.bones[bone];
    let offset = |v: Vector3<f32>| y_up(v * CM).map(|x| finite(x, 4)).join(" ");
    if b.parent.is_none() {
        writeln!(w, "{pad}ROOT {}", names[bone])?;
        writeln!(w, "{pad}{{")?;
        writeln!(w, "{pad}  OFFSET 0.0000 0.0000 0.0000")?;
        writeln!(w, "{pad}  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation")?;
    } else {
        writeln!(w, "{pad}JOINT {}", names[bone])?;
        writeln!(w, "{pad}{{")?;
        writeln!(w, "{pad}  OFFSET {}", offset(b.offset))?;
        writeln!(w, "{pad}  CHANNELS 3 Zrotation Xrotation Yrotation")?;
    }
    let children: Vec<usize> = (0..rig.bones.len()).filter(|&c| rig.bones[c].parent == Some(bone)).collect();
    if children.is_empty() {
        writeln!(w, "{pad}  End Site")?;
        writeln!(w, "{pad}  {{")?;
        writeln!(w, "{pad}    OFFSET {}", offset(b.tail))?;
        writeln!(w, "{pad}  }}")?;
    }
    for c in children {
        write_joint(w, rig, names, c, depth + 1)?;
    }
    writeln!(w, "{pad}}}")
}

/// A kit-frame local rotation as BVH's Z, X, Y Euler angles (degrees) in the Y-up frame,
/// such that the rotation is `Rz(z) * Rx(x) * Ry(y)`.
pub fn euler_zxy_deg(q: &UnitQuaternion<f32>) -> [f32; 3] {
    let [qw, qx, qy, qz] = y_up_rot(q);
    let m = UnitQuaternion::from_quaternion(Quaternion::new(qw, qx, qy, qz)).to_rotation_matrix().into_inner();
    let sx = m[(2, 1)].clamp(-1.0, 1.0);
    let x = sx.asin();
    let (z, y) = if sx.abs() < 0.99999 {
        ((-m[(0, 1)]).atan2(m[(1, 1)]), (-m[(2, 0)]).atan2(m[(2, 2)]))
    } else {
        // Gimbal lock: only z + y (or z - y) is defined; put it all on z.
        (m[(1, 0)].atan2(m[(0, 0)]), 0.0)
    };
    [z.to_degrees(), x.to_degrees(), y.to_degrees()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn euler_zxy_rebuilds_the_rotation() {
        let e = UnitQuaternion::from_euler_angles;
        let axis = |a: nalgebra::Unit<Vector3<f32>>, angle: f32| UnitQuaternion::from_axis_angle(&a, angle);
        // Plain cases, and BVH's x at exactly -90 and +90 degrees (gimbal lock) with a turn.
        let gimbal = std::f32::consts::FRAC_PI_2;
        for q in [
            e(0.3, -0.7, 1.1),
            e(2.0, 0.1, -2.5),
            e(-1.0, -1.2, 3.0),
            axis(Vector3::x_axis(), gimbal) * axis(Vector3::z_axis(), 0.7),
            axis(Vector3::z_axis(), -0.4) * axis(Vector3::x_axis(), -gimbal),
        ] {
            let [z, x, y] = euler_zxy_deg(&q).map(|d| d.to_radians());
            let r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), z)
                * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), x)
                * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), y);
            let [w, i, j, k] = y_up_rot(&q);
            let expect = UnitQuaternion::from_quaternion(Quaternion::new(w, i, j, k));
            assert!(r.angle_to(&expect) < 1e-3, "{q:?}: off by {}", r.angle_to(&expect));
        }
    }
}
