//! Reference: the real-time requirement: the twin's step allocates nothing.
//! Goal: with a counting global allocator, 2000 samples of the twin in the scenario's
//! realistic rig (measure + apply) make zero allocations.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use flexstage_sim::experiment::Command;
use flexstage_sim::rig::{RigParams, StagePlant};
use flexstage_twin::{Twin, samples};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn twin_plant_step_allocates_nothing() {
    let (s, rho) = samples::quick_rhombus().unwrap();
    let twin = Twin::from_scenario(&s, &rho).unwrap();
    let mut plant = twin.plant(&RigParams::from_scenario(&s)).unwrap();
    let cmd = |k: usize| Command {
        voltage: [500.0 + 100.0 * (k as f64 * 1e-3).sin(), 480.0],
        ..Command::default()
    };
    for k in 0..10 {
        plant.apply(&cmd(k));
    }
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    let mut sum = 0.0;
    for k in 0..2000 {
        sum += plant.measure()[0];
        plant.apply(&cmd(k));
    }
    let after = ALLOCATIONS.load(Ordering::Relaxed);
    assert!(sum.is_finite());
    assert_eq!(after - before, 0, "allocations per 2000 samples");
}
