//! The DRUMS hand network as a burn module: roll `[batch, frames, 16]` -> two stacked
//! bidirectional LSTMs (hidden `H` per direction, dropout between them) -> linear ->
//! `[batch, frames, 14]` (normalised hand values). Used for training; inference at run time
//! goes through [`crate::motion::hands::infer`], which reads the same saved weights.

use burn::module::Module;
use burn::nn::{BiLstm, BiLstmConfig, Dropout, DropoutConfig, Linear, LinearConfig};
use burn::tensor::{Device, Tensor};

use crate::motion::hands::ROLL_COLUMNS;
use crate::motion::HAND_VALUES;

/// The network. Field names are the tensor names' prefixes in the saved burnpack
/// (`lstm1.forward.input_gate.input_transform.weight`, ..., `head.weight`), which
/// [`crate::motion::hands::weights`] reads.
#[derive(Module, Debug)]
pub struct HandNet {
    pub lstm1: BiLstm,
    pub dropout: Dropout,
    pub lstm2: BiLstm,
    pub head: Linear,
}

impl HandNet {
    /// A freshly initialised network (burn's Xavier-normal LSTM and uniform linear init).
    /// `dropout` must lie in [0, 1).
    pub fn new(hidden: usize, dropout: f64, device: &Device) -> Self {
        Self {
            lstm1: BiLstmConfig::new(ROLL_COLUMNS, hidden, true).init(device),
            dropout: DropoutConfig::new(dropout).init(),
            lstm2: BiLstmConfig::new(2 * hidden, hidden, true).init(device),
            head: LinearConfig::new(2 * hidden, HAND_VALUES).init(device),
        }
    }

    /// `[batch, frames, 16]` -> `[batch, frames, 14]`. Dropout acts only on an autodiff device
    /// of a module in training mode.
    pub fn forward(&self, roll: Tensor<3>) -> Tensor<3> {
        let (z, _) = self.lstm1.forward(roll, None);
        let z = self.dropout.forward(z);
        let (z, _) = self.lstm2.forward(z, None);
        self.head.forward(z)
    }
}

/// Mean squared error over the frames where `mask` is 1: `pred`, `target` `[b, t, 14]`,
/// `mask` `[b, t, 1]` (0 on zero-padding). Averaged over valid frames and the 14 channels.
pub fn masked_mse(pred: Tensor<3>, target: Tensor<3>, mask: Tensor<3>) -> Tensor<1> {
    let channels = pred.dims()[2] as f64;
    let valid = mask.clone().sum().clamp_min(1.0);
    let err = (pred - target).square() * mask;
    err.sum() / valid.mul_scalar(channels)
}

/// Masked MSE of the frame-to-frame differences, channel `c` weighted by `weights[c]`
/// (`[1, 1, 14]`; 0 leaves a channel out), averaged over valid frame pairs and the channels
/// with a non-zero weight (`channels`). A pair is valid when both its frames are.
pub fn masked_velocity_mse(
    pred: Tensor<3>,
    target: Tensor<3>,
    mask: Tensor<3>,
    weights: Tensor<3>,
    channels: usize,
) -> Tensor<1> {
    let t = pred.dims()[1];
    let diff = |x: Tensor<3>| x.clone().narrow(1, 1, t - 1) - x.narrow(1, 0, t - 1);
    let pairs = mask.clone().narrow(1, 1, t - 1) * mask.narrow(1, 0, t - 1);
    let valid = pairs.clone().sum().clamp_min(1.0);
    let err = (diff(pred) - diff(target)).square() * weights * pairs;
    err.sum() / valid.mul_scalar(channels.max(1) as f64)
}
