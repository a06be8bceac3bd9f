//! Real-time scheduling for drumsim's own real-time threads (the live body's physics).
//!
//! A live body that falls more than [`crate::perform::paced`]'s catch-up margin behind the
//! wall clock drops periods, and a stroke in them goes unplayed. On a machine that is busy
//! besides (a browser drawing the drummer in software, a build), the ordinary scheduler
//! shares the cores fairly and the body falls behind. Audio software asks for real-time
//! scheduling for such threads (JACK clients, DAWs): `SCHED_FIFO` at priority 1, the lowest
//! real-time priority, preempts every ordinary thread and yields to audio threads, which run
//! higher. Linux lets root, or a user whose `rtprio` limit allows it (Debian's jackd2 package
//! offers the `audio` group that), ask for it; elsewhere the thread stays as it was and the
//! reason is reported.

#![allow(unsafe_code)] // two libc calls on the calling thread; each says why it holds

/// How the calling thread is scheduled after [`raise_current_thread`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Scheduling {
    /// `SCHED_FIFO` at this priority.
    RealTime(i32),
    /// The ordinary scheduler, and why not real time.
    Ordinary(String),
}

impl std::fmt::Display for Scheduling {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Scheduling::RealTime(p) => write!(f, "real-time priority (SCHED_FIFO {p})"),
            Scheduling::Ordinary(why) => write!(f, "ordinary priority ({why})"),
        }
    }
}

/// The real-time priority drumsim's threads ask for: the lowest, under any audio thread.
pub const PRIORITY: i32 = 1;

/// Ask for real-time scheduling of the calling thread; `DRUMSIM_NO_REALTIME=1` declines it.
pub fn raise_current_thread() -> Scheduling {
    raise_unless(std::env::var_os("DRUMSIM_NO_REALTIME").is_some_and(|v| v != "0"))
}

fn raise_unless(declined: bool) -> Scheduling {
    if declined {
        return Scheduling::Ordinary("DRUMSIM_NO_REALTIME is set".into());
    }
    raise(PRIORITY)
}

#[cfg(target_os = "linux")]
fn raise(priority: i32) -> Scheduling {
    let param = libc::sched_param { sched_priority: priority };
    // SAFETY: pthread_self() is the calling thread, alive for the call; `param` is a valid
    // sched_param that outlives it.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    match rc {
        0 => Scheduling::RealTime(priority),
        libc::EPERM => Scheduling::Ordinary(
            "not permitted: run as a user whose rtprio limit allows it, e.g. in the audio group".into(),
        ),
        e => Scheduling::Ordinary(std::io::Error::from_raw_os_error(e).to_string()),
    }
}

#[cfg(not(target_os = "linux"))]
fn raise(_priority: i32) -> Scheduling {
    Scheduling::Ordinary("real-time scheduling is asked for on Linux only".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whatever the machine allows, the answer is a clear one; declined, the thread stays
    /// ordinary and says so.
    #[test]
    fn a_thread_is_raised_or_says_why_not() {
        let s = std::thread::spawn(|| raise_unless(false)).join().unwrap();
        match &s {
            Scheduling::RealTime(p) => assert_eq!(*p, PRIORITY),
            Scheduling::Ordinary(why) => assert!(!why.is_empty()),
        }
        assert!(s.to_string().contains("priority"));
        let declined = std::thread::spawn(|| raise_unless(true)).join().unwrap();
        assert_eq!(declined, Scheduling::Ordinary("DRUMSIM_NO_REALTIME is set".into()));
    }
}
