//! The window search of MIDI matching and the seams between matched windows.

use super::library::{Library, LibraryError, UpperFrame};
use crate::motion::track::Pose;

/// One stage of the search: weights of missing notes, filled silences and extra notes, and
/// the cost under which a window is accepted, per note of the query window (plus one, so a
/// silent query accepts a silent match).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stage {
    pub w_miss: f32,
    pub w_sil: f32,
    pub w_extra: f32,
    pub accept_per_note: f32,
}

#[derive(Debug, Clone, PartialEq)]
pub struct MatchSettings {
    /// Window length L, frames.
    pub window: usize,
    /// The smallest window the halving goes down to.
    pub min_window: usize,
    /// Candidate windows start every `stride` frames of a clip.
    pub stride: usize,
    /// Strict first, then relaxed.
    pub stages: Vec<Stage>,
    /// Cross-fade length at a seam, frames.
    pub blend: usize,
}

impl Default for MatchSettings {
    fn default() -> Self {
        MatchSettings {
            window: 240,
            min_window: 60,
            stride: 4,
            stages: vec![
                Stage { w_miss: 4.0, w_sil: 2.0, w_extra: 1.0, accept_per_note: 0.5 },
                Stage { w_miss: 2.0, w_sil: 1.0, w_extra: 1.0, accept_per_note: 1.0 },
                Stage { w_miss: 1.0, w_sil: 0.25, w_extra: 0.5, accept_per_note: 0.8 },
            ],
            blend: 8,
        }
    }
}

/// What the search did, for reports and tests.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MatchReport {
    /// Per matched piece: query start, length, clip index, clip start, stage (stages.len()
    /// when no stage accepted it and the best was kept), cost.
    pub pieces: Vec<(usize, usize, usize, usize, usize, f32)>,
}

impl MatchReport {
    /// Windows accepted by each stage (index = stage; the last = kept without acceptance).
    pub fn by_stage(&self, stages: usize) -> Vec<usize> {
        let mut n = vec![0; stages + 1];
        for p in &self.pieces {
            n[p.4.min(stages)] += 1;
        }
        n
    }
}

/// The counts (M, S, E) of candidate `c` against query `q` (bit masks per frame); onsets
/// match up to one frame away (`cd`, `qd`: the masks dilated by one frame). The definition
/// that [`sparse_counts`] computes faster (tests hold them equal).
#[cfg(test)]
fn counts(q: &[u16], qd: &[u16], c: &[u16], cd: &[u16]) -> (u32, u32, u32) {
    let (mut m, mut s, mut e) = (0, 0, 0);
    for i in 0..q.len() {
        m += (q[i] & !cd[i]).count_ones();
        e += (c[i] & !qd[i]).count_ones();
        s += (q[i] == 0 && c[i] != 0) as u32;
    }
    (m, s, e)
}

/// The same counts from the frames that have onsets only (rolls are sparse): `q_nz` the
/// query's non-silent frames (relative), `c_nz` the candidate clip's (absolute, sorted),
/// the candidate starting at clip frame `at`.
#[allow(clippy::too_many_arguments)]
fn sparse_counts(
    q: &[u16],
    qd: &[u16],
    q_nz: &[u32],
    c: &[u16],
    cd: &[u16],
    c_nz: &[u32],
    at: usize,
) -> (u32, u32, u32) {
    let len = q.len();
    let (mut m, mut s, mut e) = (0, 0, 0);
    for &f in q_nz {
        m += (q[f as usize] & !cd[at + f as usize]).count_ones();
    }
    let lo = c_nz.partition_point(|&g| (g as usize) < at);
    let hi = c_nz.partition_point(|&g| (g as usize) < at + len);
    for &g in &c_nz[lo..hi] {
        let r = g as usize - at;
        e += (c[g as usize] & !qd[r]).count_ones();
        s += (q[r] == 0) as u32;
    }
    (m, s, e)
}

fn nonzero_frames(r: &[u16]) -> Vec<u32> {
    (0..r.len()).filter(|&i| r[i] != 0).map(|i| i as u32).collect()
}

/// Per clip: its dilated masks and its frames with onsets.
struct Sparse<'a> {
    dilated: &'a [Vec<u16>],
    nonzero: &'a [Vec<u32>],
}

fn dilate(r: &[u16]) -> Vec<u16> {
    (0..r.len()).map(|i| r[i] | if i > 0 { r[i - 1] } else { 0 } | if i + 1 < r.len() { r[i + 1] } else { 0 }).collect()
}

/// What the search needs of a library besides its clips, made once per library: it was
/// checked, and each clip's dilated masks and frames with onsets (the live motion stage plans
/// 20 times a second over the same library).
#[derive(Debug, Clone)]
pub struct MatchIndex {
    dilated: Vec<Vec<u16>>,
    nonzero: Vec<Vec<u32>>,
}

impl MatchIndex {
    /// Check `lib` and index it.
    pub fn of(lib: &Library) -> Result<MatchIndex, LibraryError> {
        lib.validate()?;
        Ok(MatchIndex {
            dilated: lib.clips.iter().map(|c| dilate(&c.roll)).collect(),
            nonzero: lib.clips.iter().map(|c| nonzero_frames(&c.roll)).collect(),
        })
    }
}

/// The upper body and face for every frame of `roll` (bit masks, see `library::mask`).
pub fn retrieve(
    lib: &Library,
    roll: &[u16],
    settings: &MatchSettings,
) -> Result<(Vec<UpperFrame>, MatchReport), LibraryError> {
    retrieve_indexed(lib, &MatchIndex::of(lib)?, roll, settings)
}

/// [`retrieve`] with the library's index made beforehand (by [`MatchIndex::of`] on `lib`).
pub fn retrieve_indexed(
    lib: &Library,
    index: &MatchIndex,
    roll: &[u16],
    settings: &MatchSettings,
) -> Result<(Vec<UpperFrame>, MatchReport), LibraryError> {
    debug_assert_eq!(index.dilated.len(), lib.clips.len(), "an index of another library");
    let sparse = Sparse { dilated: &index.dilated, nonzero: &index.nonzero };
    let qd = dilate(roll);
    let mut report = MatchReport::default();
    let mut start = 0;
    while start < roll.len() {
        let len = settings.window.min(roll.len() - start);
        search(lib, &sparse, roll, &qd, start, len, settings, &mut report);
        start += len;
    }
    report.pieces.sort_by_key(|p| p.0);
    let mut out: Vec<UpperFrame> = Vec::with_capacity(roll.len());
    for &(_, len, clip, at, _, _) in &report.pieces {
        let src = &lib.clips[clip].frames;
        let seam = out.len();
        // The previous match carries on past its end (in its own clip, when there is more).
        let carry: Vec<UpperFrame> = match out.last() {
            Some(last) => {
                let prev = report.pieces.iter().find(|p| p.0 + p.1 == seam).copied();
                (0..settings.blend.min(len))
                    .map(|k| prev.and_then(|p| lib.clips[p.2].frames.get(p.3 + p.1 + k).copied()).unwrap_or(*last))
                    .collect()
            }
            None => Vec::new(),
        };
        for k in 0..len {
            let f = src[(at + k).min(src.len() - 1)];
            out.push(match carry.get(k) {
                Some(c) => blend(c, &f, (k + 1) as f32 / (carry.len() + 1) as f32),
                None => f,
            });
        }
    }
    Ok((out, report))
}

/// Find the best library window for `roll[start..start + len]`, splitting it when no stage
/// accepts a window and it is still longer than the smallest window.
#[allow(clippy::too_many_arguments)]
fn search(
    lib: &Library,
    sparse: &Sparse,
    roll: &[u16],
    qd: &[u16],
    start: usize,
    len: usize,
    settings: &MatchSettings,
    report: &mut MatchReport,
) {
    let q = &roll[start..start + len];
    let qdw = &qd[start..start + len];
    let notes: u32 = q.iter().map(|m| m.count_ones()).sum();
    let q_nz = nonzero_frames(q);
    // Counts of every candidate, once; each stage only re-weighs them.
    let mut cands: Vec<(usize, usize, (u32, u32, u32))> = Vec::new();
    for (ci, clip) in lib.clips.iter().enumerate() {
        if clip.roll.len() < len {
            continue;
        }
        let mut at = 0;
        while at + len <= clip.roll.len() {
            let c = sparse_counts(q, qdw, &q_nz, &clip.roll, &sparse.dilated[ci], &sparse.nonzero[ci], at);
            cands.push((ci, at, c));
            at += settings.stride.max(1);
        }
    }
    let cost =
        |st: &Stage, (m, s, e): (u32, u32, u32)| st.w_miss * m as f32 + st.w_sil * s as f32 + st.w_extra * e as f32;
    for (k, st) in settings.stages.iter().enumerate() {
        let best = cands.iter().map(|&(ci, at, c)| (cost(st, c), ci, at)).min_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((c, ci, at)) = best {
            if c <= st.accept_per_note * (notes as f32 + 1.0) {
                report.pieces.push((start, len, ci, at, k, c));
                return;
            }
        }
    }
    if len / 2 >= settings.min_window {
        let half = len / 2;
        search(lib, sparse, roll, qd, start, half, settings, report);
        search(lib, sparse, roll, qd, start + half, len - half, settings, report);
        return;
    }
    // Nothing accepted at the smallest size: keep the most relaxed stage's best, or, when no
    // clip is long enough, the start of the longest clip.
    let st = settings.stages.last().copied().unwrap_or(Stage {
        w_miss: 1.0,
        w_sil: 1.0,
        w_extra: 1.0,
        accept_per_note: 0.0,
    });
    let best = cands.iter().map(|&(ci, at, c)| (cost(&st, c), ci, at)).min_by(|a, b| a.0.total_cmp(&b.0));
    let (c, ci, at) = best.unwrap_or_else(|| {
        let longest = (0..lib.clips.len()).max_by_key(|&i| lib.clips[i].frames.len()).unwrap_or(0);
        (f32::INFINITY, longest, 0)
    });
    report.pieces.push((start, len, ci, at, settings.stages.len(), c));
}

fn blend(a: &UpperFrame, b: &UpperFrame, t: f32) -> UpperFrame {
    let mut face = a.face;
    for (x, y) in face.iter_mut().zip(&b.face) {
        *x += (y - *x) * t;
    }
    UpperFrame { chest: nlerp(&a.chest, &b.chest, t), head: nlerp(&a.head, &b.head, t), face }
}

/// Position lerp and normalised quaternion lerp on the shorter arc.
fn nlerp(a: &Pose, b: &Pose, t: f32) -> Pose {
    let dot: f32 = a.rot.iter().zip(&b.rot).map(|(x, y)| x * y).sum();
    let sign = if dot < 0.0 { -1.0 } else { 1.0 };
    let mut rot: [f32; 4] = std::array::from_fn(|k| a.rot[k] + (sign * b.rot[k] - a.rot[k]) * t);
    let n = rot.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-9);
    rot.iter_mut().for_each(|x| *x /= n);
    Pose { pos: std::array::from_fn(|k| a.pos[k] + (b.pos[k] - a.pos[k]) * t), rot }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::upper::library::Clip;

    /// A clip whose frames record where they came from: chest x = clip index, y = frame.
    fn clip(ci: usize, roll: Vec<u16>) -> Clip {
        let frames = (0..roll.len())
            .map(|i| UpperFrame {
                chest: Pose { pos: [ci as f32, i as f32 * 1e-3, 1.0], rot: [1.0, 0.0, 0.0, 0.0] },
                head: Pose::IDENTITY,
                face: [ci as f32 * 0.1; 52],
            })
            .collect();
        Clip { id: format!("c{ci}"), roll, frames }
    }

    fn groove(len: usize, period: usize, bits: u16, phase: usize) -> Vec<u16> {
        (0..len).map(|i| if i % period == phase { bits } else { 0 }).collect()
    }

    #[test]
    fn the_clip_with_the_same_groove_is_chosen_at_the_right_offset() {
        // Clip 0: kick every 30 frames; clip 1: snare+hat every 15 (the query's groove).
        let lib = Library { clips: vec![clip(0, groove(1000, 30, 0b1, 0)), clip(1, groove(1000, 15, 0b1100, 3))] };
        let q = groove(480, 15, 0b1100, 10);
        let (frames, report) = retrieve(&lib, &q, &MatchSettings { stride: 1, ..MatchSettings::default() }).unwrap();
        assert_eq!(frames.len(), 480);
        assert_eq!(report.pieces.len(), 2);
        for p in &report.pieces {
            assert_eq!((p.2, p.4, p.5), (1, 0, 0.0), "{p:?}");
            // Aligned: the clip's onsets fall where the query's do.
            assert!(q[p.0..p.0 + p.1].iter().zip(&lib.clips[1].roll[p.3..]).all(|(a, b)| a == b));
        }
        assert!(frames.iter().all(|f| f.chest.pos[0] == 1.0));
    }

    #[test]
    fn a_groove_absent_from_the_library_relaxes_then_splits() {
        // The library has only straight eighths on one column; the query mixes a fill.
        let lib = Library { clips: vec![clip(0, groove(2000, 20, 0b1, 0))] };
        let mut q = groove(240, 20, 0b1, 0);
        for (i, m) in q.iter_mut().enumerate().skip(120) {
            *m = if i % 5 == 0 { 0b1110_0000 } else { 0 };
        }
        let s = MatchSettings::default();
        let (frames, report) = retrieve(&lib, &q, &s).unwrap();
        assert_eq!(frames.len(), 240);
        // The first half matches exactly; the fill half is accepted late or kept as best.
        assert!(report.pieces.len() >= 2, "{report:?}");
        assert_eq!(report.pieces[0].5, 0.0);
        assert!(report.pieces.iter().any(|p| p.4 > 0), "{report:?}");
        let covered: usize = report.pieces.iter().map(|p| p.1).sum();
        assert_eq!(covered, 240);
    }

    #[test]
    fn seams_are_cross_faded_not_cut() {
        let lib = Library { clips: vec![clip(0, groove(300, 10, 0b1, 0)), clip(1, groove(300, 7, 0b10, 0))] };
        let mut q = groove(240, 10, 0b1, 0);
        q.extend(groove(240, 7, 0b10, 0));
        let (frames, report) = retrieve(&lib, &q, &MatchSettings { stride: 1, ..MatchSettings::default() }).unwrap();
        assert_eq!(report.pieces[0].2, 0);
        assert_eq!(report.pieces[1].2, 1);
        // Across the seam at 240 the chest moves from clip 0 (x = 0) to clip 1 (x = 1) in steps.
        let xs: Vec<f32> = frames[238..252].iter().map(|f| f.chest.pos[0]).collect();
        assert!(xs.windows(2).all(|w| w[1] >= w[0] && w[1] - w[0] < 0.2), "{xs:?}");
        assert_eq!(xs[0], 0.0);
        assert_eq!(*xs.last().unwrap(), 1.0);
    }

    #[test]
    fn sparse_counts_equal_the_frame_by_frame_counts() {
        let mut x = 12345u64;
        let mut rnd = |len: usize| -> Vec<u16> {
            (0..len)
                .map(|_| {
                    x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    if (x >> 33).is_multiple_of(5) {
                        (x >> 17) as u16 & 0x0F0F
                    } else {
                        0
                    }
                })
                .collect()
        };
        let (q, c) = (rnd(240), rnd(900));
        let (qd, cd) = (dilate(&q), dilate(&c));
        let (q_nz, c_nz) = (nonzero_frames(&q), nonzero_frames(&c));
        for at in (0..=660).step_by(7) {
            let dense = counts(&q, &qd, &c[at..at + 240], &cd[at..at + 240]);
            assert_eq!(sparse_counts(&q, &qd, &q_nz, &c, &cd, &c_nz, at), dense, "at {at}");
        }
    }

    #[test]
    fn short_queries_and_short_libraries_still_get_poses() {
        let lib = Library { clips: vec![clip(0, groove(50, 10, 0b1, 0))] };
        let (frames, _) = retrieve(&lib, &groove(500, 10, 0b1, 0), &MatchSettings::default()).unwrap();
        assert_eq!(frames.len(), 500);
        let (frames, _) = retrieve(&lib, &[], &MatchSettings::default()).unwrap();
        assert!(frames.is_empty());
        assert!(matches!(retrieve(&Library::default(), &[1], &MatchSettings::default()), Err(LibraryError::Empty)));
    }
}
