//! Zero heap allocations per step through the packaged FMUs' C interface (`fmi2SetReal`,
//! `fmi2DoStep`, `fmi2GetReal` of the built libraries, loaded with `fmi2-import`).
//!
//! A test binary's counting allocator sees only its own allocations: each FMU's shared
//! library has its own global allocator. Both end in the process's `malloc`, so the test
//! runs itself again with the malloc counter of `tests/fixtures/malloc-count` preloaded
//! (`LD_PRELOAD`), which counts the libraries' allocations too. Linux (glibc) only.
#![cfg(target_os = "linux")]

mod common;

use std::path::Path;
use std::process::Command;

use alloc_count::{CountingAllocator, allocations, preloaded_allocations};
use fmi2_import::{Fmu, Instance};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Set in the child process that measures.
const CHILD: &str = "CKCM_MALLOC_COUNT_CHILD";
const H: f64 = 1e-3;

fn vrs(f: &Fmu, base: &str) -> [u32; 6] {
    std::array::from_fn(|i| {
        f.model_description()
            .variable_by_name(&format!("{base}[{}]", i + 1))
            .unwrap_or_else(|| panic!("no {base}"))
            .value_reference
    })
}

fn start(inst: &mut Instance) {
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
}

/// Compiles the malloc counter with the system C compiler (`$CC`, else `cc`).
fn build_counter(dir: &Path) -> std::path::PathBuf {
    let src = common::workspace_root().join("tests/fixtures/malloc-count/malloc_count.c");
    let lib = dir.join("libmalloc_count.so");
    let cc = std::env::var_os("CC").unwrap_or_else(|| "cc".into());
    let status = Command::new(&cc)
        .args(["-shared", "-fPIC", "-O2", "-o"])
        .arg(&lib)
        .arg(&src)
        .arg("-ldl")
        .status()
        .unwrap_or_else(|e| panic!("cannot run the C compiler {cc:?}: {e}"));
    assert!(status.success(), "{cc:?} could not build {}", src.display());
    lib
}

#[test]
fn closed_loop_steps_through_the_c_interface_do_not_allocate() {
    if std::env::var_os(CHILD).is_some() {
        measure();
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let counter = build_counter(dir.path());
    let out = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "closed_loop_steps_through_the_c_interface_do_not_allocate",
            "--nocapture",
            "--test-threads=1",
        ])
        .env("LD_PRELOAD", &counter)
        .env(CHILD, "1")
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "the measuring run failed:\n{text}");
    // The child really measured (a filter typo would run nothing and succeed).
    assert!(
        text.contains("1 passed"),
        "the measuring run ran no test:\n{text}"
    );
}

/// In the child: the HLCS loop of the two packaged FMUs, 1000 steps after a warm-up, with
/// every input set and every output read through the C interface.
fn measure() {
    assert!(
        preloaded_allocations().is_some(),
        "the malloc counter is not preloaded"
    );
    let plant = Fmu::open(common::built_fmu("CkcmPlant")).unwrap();
    let ctl = Fmu::open(common::built_fmu("HlcsController")).unwrap();
    let mut p = plant.instantiate("plant", false).unwrap();
    let mut c = ctl.instantiate("controller", false).unwrap();
    start(&mut p);
    start(&mut c);
    let (p_force, p_length, p_velocity) = (
        vrs(&plant, "force"),
        vrs(&plant, "length"),
        vrs(&plant, "velocity"),
    );
    let (c_length, c_velocity, c_memory, c_force, c_next) = (
        vrs(&ctl, "length"),
        vrs(&ctl, "velocity"),
        vrs(&ctl, "memory"),
        vrs(&ctl, "force"),
        vrs(&ctl, "memory_next"),
    );
    let mut y = [0.0; 6];
    let mut yd = [0.0; 6];
    let mut f = [0.0; 6];
    let mut next = [0.0; 6];
    let mut step = |n: u32, p: &mut Instance, c: &mut Instance| {
        let t = f64::from(n) * H;
        p.get_real(&p_length, &mut y).unwrap();
        p.get_real(&p_velocity, &mut yd).unwrap();
        c.set_real(&c_length, &y).unwrap();
        c.set_real(&c_velocity, &yd).unwrap();
        c.set_real(&c_memory, &next).unwrap();
        c.do_step(t, H, true).unwrap();
        c.get_real(&c_force, &mut f).unwrap();
        c.get_real(&c_next, &mut next).unwrap();
        p.set_real(&p_force, &f).unwrap();
        p.do_step(t, H, true).unwrap();
    };
    for n in 0..10 {
        step(n, &mut p, &mut c);
    }
    let (before, rust_before) = (preloaded_allocations().unwrap(), allocations());
    for n in 10..1010 {
        step(n, &mut p, &mut c);
    }
    let (after, rust_after) = (preloaded_allocations().unwrap(), allocations());
    assert_eq!(
        after - before,
        0,
        "1000 closed-loop steps made {} allocations",
        after - before
    );
    assert_eq!(rust_after, rust_before);
    // The loop ran: the platform moved under learning forces.
    assert!(y.iter().all(|l| l.is_finite()) && next.iter().any(|&u| u != 0.0));

    // The counter does see the libraries' own allocations, which this binary's counting
    // allocator does not: fmi2GetFMUstate allocates the state inside the library.
    let (before, rust_before) = (preloaded_allocations().unwrap(), allocations());
    let state = p.get_fmu_state().unwrap();
    let (after, rust_after) = (preloaded_allocations().unwrap(), allocations());
    let library = (after - before) - (rust_after - rust_before) as u64;
    assert!(
        library > 0,
        "no allocation seen inside the library ({} in all)",
        after - before
    );
    drop(state);
}
