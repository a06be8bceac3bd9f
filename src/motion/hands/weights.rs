//! A hand-model checkpoint (burnpack, written by `HandNet::save_file`) read into plain `f32`
//! arrays, with the four LSTM gates of each direction fused, for [`super::infer`].
//!
//! burn's LSTM keeps one `Linear` per gate and per source (input, hidden), each weight
//! `[d_in, d_out]` row-major, both with a bias. Here a direction is `w_ih [d_in][4H]`,
//! `w_hh [H][4H]` and one bias `[4H]` (input + hidden bias), gates in the order
//! input, forget, cell, output.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use burn::store::burn_pack::{Bytes, DType, Reader};

use super::{HandsError, ROLL_COLUMNS};
use crate::motion::HAND_VALUES;

/// Gate names in burn's LSTM, in our fused order (i, f, g, o).
const GATES: [&str; 4] = ["input_gate", "forget_gate", "cell_gate", "output_gate"];
/// Layer and direction module names in [`super::model::HandNet`].
const LAYERS: [&str; 2] = ["lstm1", "lstm2"];
const DIRECTIONS: [&str; 2] = ["forward", "reverse"];

/// One direction of one LSTM layer, gates fused.
#[derive(Debug, Clone, PartialEq)]
pub struct DirWeights {
    /// `[d_in][4H]` row-major.
    pub w_ih: Vec<f32>,
    /// `[H][4H]` row-major.
    pub w_hh: Vec<f32>,
    /// `[4H]`: input and hidden biases summed.
    pub bias: Vec<f32>,
}

/// The whole network in plain arrays.
#[derive(Debug, Clone, PartialEq)]
pub struct HandWeights {
    /// Hidden units per direction (`H`).
    pub hidden: usize,
    /// `layers[layer][direction]`, direction 0 forward, 1 reverse.
    pub layers: [[DirWeights; 2]; 2],
    /// `[2H][14]` row-major.
    pub head_w: Vec<f32>,
    pub head_b: [f32; HAND_VALUES],
}

/// Raw tensors by name: shape and values.
struct Tensors {
    path: PathBuf,
    map: HashMap<String, (Vec<usize>, Vec<f32>)>,
}

impl Tensors {
    fn read(path: &Path) -> Result<Self, HandsError> {
        let err = |reason: String| HandsError::Read { path: path.to_path_buf(), reason };
        if !path.is_file() {
            return Err(err("no such file".into()));
        }
        let reader = Reader::from_file_exact(path).map_err(|e| err(e.to_string()))?;
        Self::from_reader(reader, path)
    }

    /// Tensors from a checkpoint in memory; `path` names it in errors.
    fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, HandsError> {
        let err = |reason: String| HandsError::Read { path: path.to_path_buf(), reason };
        let reader = Reader::from_bytes(Bytes::from_bytes_vec(bytes.to_vec())).map_err(|e| err(e.to_string()))?;
        Self::from_reader(reader, path)
    }

    fn from_reader(reader: Reader, path: &Path) -> Result<Self, HandsError> {
        let err = |reason: String| HandsError::Read { path: path.to_path_buf(), reason };
        let mut map = HashMap::new();
        for t in reader.into_tensors().map_err(|e| err(e.to_string()))? {
            if t.dtype != DType::F32 {
                return Err(HandsError::Invalid {
                    path: path.to_path_buf(),
                    reason: format!("tensor `{}` is {:?}, expected f32", t.name, t.dtype),
                });
            }
            let shape = t.shape.as_slice().to_vec();
            let bytes = t.to_bytes().map_err(|e| err(e.to_string()))?;
            let values: Vec<f32> =
                bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
            if values.len() != shape.iter().product::<usize>() {
                return Err(err(format!("tensor `{}` holds {} values for shape {shape:?}", t.name, values.len())));
            }
            if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
                return Err(HandsError::Invalid {
                    path: path.to_path_buf(),
                    reason: format!("tensor `{}` has a non-finite value at {bad}", t.name),
                });
            }
            map.insert(t.name.clone(), (shape, values));
        }
        Ok(Self { path: path.to_path_buf(), map })
    }

    fn shape(&self, name: &str) -> Result<&[usize], HandsError> {
        self.map
            .get(name)
            .map(|(s, _)| s.as_slice())
            .ok_or_else(|| HandsError::MissingTensor { path: self.path.clone(), name: name.into() })
    }

    /// The values of `name`, checked to have shape `expected`.
    fn get(&self, name: &str, expected: &[usize]) -> Result<&[f32], HandsError> {
        let shape = self.shape(name)?;
        if shape != expected {
            return Err(HandsError::Shape {
                path: self.path.clone(),
                name: name.into(),
                found: shape.to_vec(),
                expected: expected.to_vec(),
            });
        }
        Ok(&self.map[name].1)
    }
}

impl HandWeights {
    /// Reads a checkpoint; every tensor's presence, shape, dtype and finiteness is checked.
    pub fn load(path: &Path) -> Result<Self, HandsError> {
        Self::from_tensors(Tensors::read(path)?, path)
    }

    /// Reads a checkpoint held in memory (the compiled-in weights); `path` names it in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, HandsError> {
        Self::from_tensors(Tensors::from_bytes(bytes, path)?, path)
    }

    fn from_tensors(t: Tensors, path: &Path) -> Result<Self, HandsError> {
        let probe = "lstm1.forward.input_gate.hidden_transform.weight";
        let hidden = match t.shape(probe)? {
            [h, h2] if h == h2 && *h > 0 => *h,
            other => {
                return Err(HandsError::Shape {
                    path: path.to_path_buf(),
                    name: probe.into(),
                    found: other.to_vec(),
                    expected: vec![0, 0],
                })
            }
        };
        let layer = |l: usize| -> Result<[DirWeights; 2], HandsError> {
            let d_in = if l == 0 { ROLL_COLUMNS } else { 2 * hidden };
            let dir = |d: usize| -> Result<DirWeights, HandsError> {
                let g4 = 4 * hidden;
                let mut w =
                    DirWeights { w_ih: vec![0.0; d_in * g4], w_hh: vec![0.0; hidden * g4], bias: vec![0.0; g4] };
                for (g, gate) in GATES.iter().enumerate() {
                    let p = format!("{}.{}.{gate}", LAYERS[l], DIRECTIONS[d]);
                    let wi = t.get(&format!("{p}.input_transform.weight"), &[d_in, hidden])?;
                    let wh = t.get(&format!("{p}.hidden_transform.weight"), &[hidden, hidden])?;
                    let bi = t.get(&format!("{p}.input_transform.bias"), &[hidden])?;
                    let bh = t.get(&format!("{p}.hidden_transform.bias"), &[hidden])?;
                    for k in 0..d_in {
                        w.w_ih[k * g4 + g * hidden..][..hidden].copy_from_slice(&wi[k * hidden..][..hidden]);
                    }
                    for k in 0..hidden {
                        w.w_hh[k * g4 + g * hidden..][..hidden].copy_from_slice(&wh[k * hidden..][..hidden]);
                    }
                    for j in 0..hidden {
                        w.bias[g * hidden + j] = bi[j] + bh[j];
                    }
                }
                Ok(w)
            };
            Ok([dir(0)?, dir(1)?])
        };
        let layers = [layer(0)?, layer(1)?];
        let head_w = t.get("head.weight", &[2 * hidden, HAND_VALUES])?.to_vec();
        let mut head_b = [0.0; HAND_VALUES];
        head_b.copy_from_slice(t.get("head.bias", &[HAND_VALUES])?);
        Ok(Self { hidden, layers, head_w, head_b })
    }
}
