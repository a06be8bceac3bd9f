//! Arithmetic on a lane of eight modes, by value: explicit AVX2 instructions where the
//! processor has them (pulp's `V3`, chosen at run time), plain arrays elsewhere. The modal
//! bank's loops are written once over [`LaneOps`]; left to the vectoriser, the same loops
//! came out as eight-wide instructions in one build and as gathered scalars with the sums
//! kept on the stack in the next (2x slower), depending on what else was inlined.
//! Neither form fuses a multiply with an add, so both give the same samples bit for bit.

use super::bank::{Lane, LANES};

/// Lane-wise arithmetic.
pub trait LaneOps: Copy {
    fn add(self, a: Lane, b: Lane) -> Lane;
    fn sub(self, a: Lane, b: Lane) -> Lane;
    fn mul(self, a: Lane, b: Lane) -> Lane;
    #[inline(always)]
    fn splat(self, a: f32) -> Lane {
        [a; LANES]
    }
}

/// Plain arrays (what the vectoriser makes of them).
#[derive(Debug, Clone, Copy)]
pub struct Portable;

impl LaneOps for Portable {
    #[inline(always)]
    fn add(self, a: Lane, b: Lane) -> Lane {
        std::array::from_fn(|l| a[l] + b[l])
    }
    #[inline(always)]
    fn sub(self, a: Lane, b: Lane) -> Lane {
        std::array::from_fn(|l| a[l] - b[l])
    }
    #[inline(always)]
    fn mul(self, a: Lane, b: Lane) -> Lane {
        std::array::from_fn(|l| a[l] * b[l])
    }
}

#[cfg(target_arch = "x86_64")]
impl LaneOps for pulp::x86::V3 {
    #[inline(always)]
    fn add(self, a: Lane, b: Lane) -> Lane {
        pulp::cast(self.add_f32x8(pulp::cast(a), pulp::cast(b)))
    }
    #[inline(always)]
    fn sub(self, a: Lane, b: Lane) -> Lane {
        pulp::cast(self.sub_f32x8(pulp::cast(a), pulp::cast(b)))
    }
    #[inline(always)]
    fn mul(self, a: Lane, b: Lane) -> Lane {
        pulp::cast(self.mul_f32x8(pulp::cast(a), pulp::cast(b)))
    }
}

/// Run `f` with the best [`LaneOps`] this processor has, compiled for it.
#[inline(always)]
pub fn dispatch<R>(f: impl LaneFn<R>) -> R {
    #[cfg(target_arch = "x86_64")]
    if let Some(v3) = pulp::x86::V3::try_new() {
        return v3.vectorize(
            #[inline(always)]
            || f.call(v3),
        );
    }
    f.call(Portable)
}

/// A computation generic over the lane arithmetic (a closure cannot be).
pub trait LaneFn<R> {
    fn call<O: LaneOps>(self, o: O) -> R;
}
