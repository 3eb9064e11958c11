//! A model's saved state (the payload the glue wraps in its header and checksum) from the
//! fuzzer, restored into a fresh model as fmi2DeSerializeFMUstate does: refused with an
//! error, or accepted into a state that saves back consistently and from which steps
//! succeed with finite outputs or fail with an error. A panic, a hang or a huge allocation
//! is a finding.
//!
//! The first byte picks the form: the input's bytes as they are, or a state
//! saved after a few steps with the input's bytes XORed into it at an offset (so that the
//! fuzzer reaches the fields behind the parameters without rebuilding them).
use std::sync::OnceLock;

#[path = "outputs.rs"]
mod outputs;

use fmu_core::Model;

fn saved<M: Model>(model: &M) -> Vec<u8> {
    let mut out = Vec::new();
    model.save(&mut out);
    out
}

/// A state after initialization and `steps` steps of 1 ms.
fn baseline<M: Model>(steps: usize) -> Vec<u8> {
    let mut m = M::new();
    m.initialize(0.0).expect("default parameters initialize");
    for k in 0..steps {
        m.do_step(k as f64 * 1e-3, 1e-3)
            .expect("default parameters step");
    }
    saved(&m)
}

fn check<M: Model>(payload: &[u8], steps: u8) {
    let mut m = M::new();
    if m.restore(payload).is_err() || fmu_core::check_ranges(&m).is_err() {
        return;
    }
    // Saved again and restored, the state saves to the same bytes.
    let once = saved(&m);
    let mut again = M::new();
    again
        .restore(&once)
        .expect("a state this model saved restores");
    assert_eq!(
        saved(&again),
        once,
        "save → restore → save changed the bytes"
    );
    let mut t = 0.0;
    for _ in 0..steps % 16 {
        if m.do_step(t, 1e-3).is_err() {
            return;
        }
        t += 1e-3;
        outputs::outputs_finite(&m, "after a step");
    }
}

/// One fuzz input. `baseline_state` keeps the state saved after 20 steps, made on first use.
pub fn run<M: Model>(bytes: &[u8], baseline_state: &OnceLock<Vec<u8>>) {
    let [mode, steps, rest @ ..] = bytes else {
        return;
    };
    let payload = if mode & 1 == 0 {
        rest.to_vec()
    } else {
        let mut base = baseline_state.get_or_init(|| baseline::<M>(20)).clone();
        let [a, b, xor @ ..] = rest else {
            return;
        };
        let at = usize::from(u16::from_le_bytes([*a, *b])) % (base.len() + 1);
        for (i, x) in xor.iter().enumerate() {
            if let Some(byte) = base.get_mut(at + i) {
                *byte ^= x;
            }
        }
        base
    };
    check::<M>(&payload, *steps);
}
