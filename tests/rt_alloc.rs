//! The live body's physics thread on the product's allocator (`rt_alloc::RtPool`, the binary's
//! global allocator): in steady state nothing it runs reaches the system allocator (rapier
//! allocates on every step; those allocations come from the thread's own free lists).

use drumsim::kit::Kit;
use drumsim::rt_alloc::RtPool;

#[global_allocator]
static ALLOCATOR: RtPool = RtPool;

/// The live physical drummer's physics thread (`perform::paced`) in steady state: a newer
/// window plan swapped in every 50 ms, the body's task periods with their contacts and hi-hat
/// messages going out, on 12 s of a Groove MIDI validation take. The plans are made outside
/// (on the planner's thread in live play); only what the physics thread runs is watched: on a thread that entered the product's
/// allocator (`rt_alloc::RtPool`), none of it reaches the system allocator.
#[test]
fn the_live_body_never_calls_the_system_allocator_in_steady_state() {
    assert!(RtPool::enter(256 << 20));
    use drumsim::midi::{read_file, NoteMap, ReadOptions};
    use drumsim::motion::hands::HandModel;
    use drumsim::motion::pipeline::shipped_library;
    use drumsim::motion::window::WindowMotion;
    use drumsim::perform::conductor::{Conductor, TargetShape};
    use drumsim::perform::paced::{play_period, take_plans, BodyPlanner, FrameOut, PacedStats};
    use std::sync::atomic::Ordering::Relaxed;

    let kit = Kit::builtin_default();
    let map = NoteMap::builtin("roland-td").unwrap();
    let take = concat!(env!("CARGO_MANIFEST_DIR"), "/data/gmd/drummer1/session2/1_latin-chacarera_157_beat_3-4.mid");
    let perf = read_file(std::path::Path::new(take), &ReadOptions { channel: 10 }).unwrap();
    let settings = drumsim::body::sim::DrummerSettings::default();
    let shape = TargetShape::of(&drumsim::body::sim::Drummer::new(&kit, settings.clone()).unwrap());
    let planner = BodyPlanner::new(shape, &kit, &map);
    let (lookahead, delay) = (0.25, 0.225);
    let mut window =
        WindowMotion::new(kit.clone(), map.clone(), HandModel::shipped(), shipped_library().unwrap(), lookahead);
    let first = planner.plan(&window.plan(0.0).unwrap());
    let mut c = Conductor::live(&kit, settings, first.targets, first.pedals, -delay).unwrap();
    let (plan_tx, plan_rx) = crossbeam_channel::bounded(1);
    let (spent_tx, spent_rx) = crossbeam_channel::bounded(4);
    let (out_tx, out_rx) = crossbeam_channel::bounded(4096);
    let stats = PacedStats::default();
    let mut hihat = FrameOut::new(c.time_s(), true);
    let mut events = perf.events.iter().peekable();
    let mut next_plan = 0.05;
    let (mut watched, mut contacts, mut system_calls) = (0u64, 0usize, 0u64);
    let mut served = 0u64;
    while c.time_s() < 12.0 {
        let wall = c.time_s() + 0.004 + delay;
        if next_plan <= wall {
            while let Some(e) = events.next_if(|e| e.time_s <= next_plan) {
                window.push(*e);
            }
            plan_tx.try_send(planner.plan(&window.plan(next_plan).unwrap())).unwrap();
            next_plan += 0.05;
        }
        let steady = c.time_s() > 3.0;
        let (before, served_before) = (RtPool::system_calls(), RtPool::served());
        take_plans(&mut c, &plan_rx, &spent_tx, &stats);
        play_period(&mut c, &mut hihat, &out_tx, &stats);
        if steady {
            system_calls += RtPool::system_calls() - before;
            served += RtPool::served() - served_before;
            watched += 1;
        }
        while spent_rx.try_recv().is_ok() {}
        contacts +=
            out_rx.try_iter().filter(|o| steady && matches!(o, drumsim::perform::paced::BodyOut::Strike(_))).count();
    }
    assert!(watched > 2000 && contacts > 50, "{watched} periods watched, {contacts} contacts");
    assert!(stats.replans.load(Relaxed) > 200);
    assert_eq!(stats.out_full.load(Relaxed) + stats.spent_here.load(Relaxed), 0);
    println!("{watched} periods: {served} allocations served by the thread's pool, {system_calls} by the system");
    assert!(served > watched, "rapier allocates on every step: the pool served them");
    assert_eq!(system_calls, 0, "the physics thread called the system allocator in {watched} periods");
    // And the count can tell: an allocation too large for the pool reaches the system.
    let before = RtPool::system_calls();
    drop(std::hint::black_box(vec![0u8; 1 << 20]));
    assert_eq!(RtPool::system_calls() - before, 2, "a 1 MiB block: its allocation and its free");
}
