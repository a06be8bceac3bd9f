//! Flush-to-zero for the threads that run the modal bank: decaying modes would otherwise go
//! subnormal, and subnormal arithmetic costs about 50x (measured on these machines).

/// Run `f` with flush-to-zero and denormals-are-zero set, restoring the previous mode after.
#[allow(unsafe_code)]
pub fn with_flush_to_zero<R>(f: impl FnOnce() -> R) -> R {
    // SAFETY: no_denormals sets FTZ/DAZ (MXCSR on x86, FPCR on aarch64) only for the duration
    // of `f` and restores the saved mode afterwards, on this thread only. Code inside `f` is
    // our own float DSP, which is correct with subnormals flushed to zero (they are below
    // -700 dB); nothing inside relies on gradual underflow.
    unsafe { no_denormals::no_denormals(f) }
}
