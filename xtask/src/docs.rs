//! `documentation/index.html` of each FMU, generated from its model description so the
//! variables table can never disagree with the interface.

use std::fmt::Write;

use fmi2_md::{ModelDescription, VariableKind};

/// What a user must know beyond the variables table, per model identifier.
fn semantics(model_identifier: &str) -> &'static str {
    match model_identifier {
        "CkcmPlant" => {
            "<p>A 6-DOF closed-kinematic-chain manipulator (Stewart platform) with two-body legs \
             (cylinder hinged at the base, rod ball-jointed to the platform), actuator friction and \
             gravity. Each actuator's friction is &minus;<code>viscous_friction</code> l&#775; &minus; \
             <code>coulomb_friction</code> s(l&#775; / <code>friction_velocity</code>), with s = tanh \
             (the default) or, with <code>friction_curve</code> = algebraic, s(x) = x / &radic;(1 + x&sup2;): \
             a cheaper curve with the same slope at rest and the same limits, but a different model. \
             The six <code>force</code> inputs are held constant over each communication step; \
             the rigid-body model is integrated over the step with RK4 (<code>substeps</code> per step, \
             more where the step is longer than <code>rk4_max_step</code>, 1 ms by default) or \
             adaptive Dormand&ndash;Prince 5(4) (<code>relative_tolerance</code>, <code>absolute_tolerance</code>). \
             The outputs at a communication point are the state at that time, so they do not depend \
             directly on the inputs (no direct feedthrough). Variable communication step sizes are \
             supported. The platform starts at rest at home (0, 0, <code>home_height</code>) plus \
             <code>initial_pose</code>.</p>\
             <p>A non-finite input is rejected by fmi2SetReal with fmi2Error naming the variable; a \
             step that would take a leg beyond its stroke, a platform joint to the base plane or \
             the state to a non-finite value returns fmi2Discard with a message naming the cause \
             and the time, never NaN outputs.</p>\
             <p>Reference figure: holding all six forces at 28.5315 N keeps the platform at home.</p>"
        }
        "HlcsController" => {
            "<p>The hybrid learning control scheme: PID feedback in leg space, model-based \
             feedforward J<sup>-T</sup>(M a<sub>d</sub> + b) from the controller's nominal model \
             (<code>model.*</code> parameters: the plant without the rod), and a PID-type iterative \
             learning controller.</p>\
             <p><b>Sampled semantics.</b> fmi2DoStep(t<sub>n</sub>, h) evaluates the law with the inputs \
             set at t<sub>n</sub>; the outputs read after the step are the values to hold over \
             [t<sub>n</sub>, t<sub>n</sub>+h]. After initialization the outputs preview the law at the start \
             time (integral term still zero). With e = l<sub>d</sub> &minus; l, &edot; = l&#775;<sub>d</sub> &minus; l&#775; \
             and I<sub>n</sub> = I<sub>n-1</sub> + e h:</p>\
             <pre>force       = kp e + kd ė + ki I + memory + feedforward\n\
memory_next = memory + phi e + gamma ė + psi I     (learning on)\n\
memory_next = memory                               (learning off)</pre>\
             <p><b>Wiring for learning.</b> A master stores <code>memory_next</code> of every sample of \
             trial k and feeds it back as <code>memory</code> at the same sample of trial k+1 (zero in trial 0), \
             resetting both FMUs to the same initial state between trials. Couple in Gauss&ndash;Seidel \
             order: set the controller inputs from the plant outputs at t<sub>n</sub>, step the controller, \
             pass <code>force</code> to the plant, step the plant. A Jacobi master adds one step of delay.</p>"
        }
        _ => "",
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The whole page.
pub fn index_html(md: &ModelDescription) -> String {
    let id = md
        .co_simulation
        .as_ref()
        .map_or("", |c| c.model_identifier.as_str());
    let mut h = String::new();
    // Writing into a String cannot fail.
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{name}</title>\
         <style>body{{font-family:sans-serif;max-width:70em;margin:auto}}table{{border-collapse:collapse}}\
         td,th{{border:1px solid #ccc;padding:2px 6px;text-align:left;vertical-align:top}}</style></head><body>\
         <h1>{name}</h1><p>{desc}</p><p>FMI 2.0 Co-Simulation, GUID <code>{guid}</code>, version {ver}. \
         Default experiment: step size {step} s, stop time {stop} s. All values in SI units; angles in rad \
         (display unit deg).</p><h2>Semantics</h2>{sem}<h2>Variables</h2><table><tr><th>name</th><th>vr</th>\
         <th>causality</th><th>variability</th><th>type</th><th>unit</th><th>start</th><th>description</th></tr>",
        name = esc(&md.model_name),
        desc = esc(md.description.as_deref().unwrap_or("")),
        guid = esc(&md.guid),
        ver = esc(md.version.as_deref().unwrap_or("")),
        step = md
            .default_experiment
            .as_ref()
            .and_then(|d| d.step_size)
            .unwrap_or(f64::NAN),
        stop = md
            .default_experiment
            .as_ref()
            .and_then(|d| d.stop_time)
            .unwrap_or(f64::NAN),
        sem = semantics(id),
    );
    for v in &md.model_variables {
        let (ty, unit, start) = match &v.kind {
            VariableKind::Real {
                unit,
                display_unit,
                start,
                ..
            } => (
                "Real".to_string(),
                match (unit, display_unit) {
                    (Some(u), Some(d)) => format!("{u} (display {d})"),
                    (Some(u), None) => u.clone(),
                    _ => String::new(),
                },
                start.map(|s| s.to_string()).unwrap_or_default(),
            ),
            VariableKind::Integer { start, .. } => (
                "Integer".into(),
                String::new(),
                start.map(|s| s.to_string()).unwrap_or_default(),
            ),
            VariableKind::Boolean { start } => (
                "Boolean".into(),
                String::new(),
                start.map(|s| s.to_string()).unwrap_or_default(),
            ),
            VariableKind::String { start } => (
                "String".into(),
                String::new(),
                start.clone().unwrap_or_default(),
            ),
            VariableKind::Enumeration {
                declared_type,
                start,
                ..
            } => {
                let items = md
                    .type_definitions
                    .iter()
                    .find(|t| &t.name == declared_type)
                    .and_then(|t| match &t.kind {
                        fmi2_md::SimpleTypeKind::Enumeration { items, .. } => Some(items),
                        _ => None,
                    });
                let start_name = items
                    .and_then(|items| items.iter().find(|i| Some(i.value) == *start))
                    .map(|i| format!("{} ({})", start.unwrap_or(0), i.name))
                    .unwrap_or_else(|| start.map(|s| s.to_string()).unwrap_or_default());
                let all = items
                    .map(|items| {
                        items
                            .iter()
                            .map(|i| format!("{}={}", i.value, i.name))
                            .collect::<Vec<_>>()
                            .join(", ")
                    })
                    .unwrap_or_default();
                (
                    format!("Enumeration {declared_type}: {all}"),
                    String::new(),
                    start_name,
                )
            }
        };
        let _ = write!(
            h,
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&v.name),
            v.value_reference,
            v.causality.as_str(),
            v.variability.as_str(),
            esc(&ty),
            esc(&unit),
            esc(&start),
            esc(v.description.as_deref().unwrap_or("")),
        );
    }
    h.push_str("</table></body></html>\n");
    h
}
