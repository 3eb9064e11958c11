//! The importer against a real (tiny, C) FMI 2.0 binary: instantiate, log, call, states.

#[path = "support/mod.rs"]
mod import_support;

use fmi2_import::Status;
use fmi2_import::{Fmu, ImportError};

fn open() -> (tempfile::TempDir, Fmu) {
    let dir = tempfile::tempdir().unwrap();
    let fmu = Fmu::open(import_support::dummy_fmu(dir.path())).unwrap();
    (dir, fmu)
}

/// `dir/MiniPlatform.fmu` with the dummy binary and `extra` entries.
fn dummy_fmu_and(dir: &std::path::Path, extra: &[(&str, &[u8])]) -> std::path::PathBuf {
    let path = dir.join("MiniPlatform.fmu");
    fmu_build::write_fmu(
        &path,
        import_support::MODEL_DESCRIPTION,
        Some(import_support::dummy_library()),
        extra,
    )
    .unwrap();
    path
}

/// Only this platform's binaries are unpacked, and `platforms` still lists every platform
/// folder of the archive; every other entry is unpacked, byte for byte.
#[test]
fn other_platforms_binaries_stay_in_the_archive() {
    let dir = tempfile::tempdir().unwrap();
    let path = dummy_fmu_and(
        dir.path(),
        &[
            ("binaries/win64/MiniPlatform.dll", b"MZ"),
            ("binaries/darwin64/MiniPlatform.dylib", b"x"),
            ("resources/table.csv", b"t,x\n0,1\n"),
            ("documentation/index.html", b"<p>doc</p>"),
            ("sources/model.c", b"int x;"),
        ],
    );
    let fmu = Fmu::open(&path).unwrap();
    let mut expected = vec![
        "darwin64".to_string(),
        "win64".into(),
        fmi2_import::PLATFORM.into(),
    ];
    expected.sort();
    assert_eq!(fmu.platforms(), expected);
    let unpacked = fmu.unpacked_dir();
    let binaries: Vec<String> = std::fs::read_dir(unpacked.join("binaries"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(binaries, [fmi2_import::PLATFORM]);
    for (name, bytes) in [
        ("resources/table.csv", &b"t,x\n0,1\n"[..]),
        ("documentation/index.html", b"<p>doc</p>"),
        ("sources/model.c", b"int x;"),
    ] {
        assert_eq!(std::fs::read(unpacked.join(name)).unwrap(), bytes, "{name}");
    }
    // The binary that was unpacked is the one that runs.
    let mut inst = fmu.instantiate("a", false).unwrap();
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
}

/// An entry that would land outside the extraction folder fails the open, naming the file,
/// whether or not other platforms' binaries are left out; nothing is written outside.
#[test]
fn an_escaping_entry_is_refused_with_or_without_foreign_binaries() {
    for foreign in [false, true] {
        let dir = tempfile::tempdir().unwrap();
        let mut extra: Vec<(&str, &[u8])> = vec![("../../escaped.txt", b"out")];
        if foreign {
            extra.push(("binaries/win64/MiniPlatform.dll", b"MZ"));
            // Under another platform's folder too: refused, not skipped as a foreign binary.
            extra[0].0 = "binaries/win64/../../../../escaped.txt";
        }
        let path = dummy_fmu_and(dir.path(), &extra);
        let err = Fmu::open(&path).unwrap_err();
        assert!(matches!(err, ImportError::Unpack { .. }), "{err:?}");
        assert!(
            err.to_string().contains(&path.display().to_string()),
            "{err}"
        );
        // Two levels up from `<temp>/fmi2-import-<pid>-*/`.
        let tmp = std::env::temp_dir();
        let above = tmp.parent().unwrap_or(&tmp);
        assert!(!above.join("escaped.txt").exists());
    }
}

/// A symbolic link in the archive that points outside the extraction folder, absolute or
/// relative, with a file to be written through it: the open fails naming the file, and
/// nothing lands where the link points.
#[test]
fn a_symbolic_link_out_of_the_folder_is_refused() {
    let outside = tempfile::tempdir().unwrap();
    let target = outside.path().display().to_string();
    for link in [target.as_str(), "../..", "../../.."] {
        let dir = tempfile::tempdir().unwrap();
        let path = dummy_fmu_and(dir.path(), &[]);
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&path)
            .unwrap();
        let mut zip = zip::ZipWriter::new_append(file).unwrap();
        let options = zip::write::SimpleFileOptions::default();
        zip.add_symlink("resources/link", link, options).unwrap();
        zip.start_file("resources/link/escaped.txt", options)
            .unwrap();
        std::io::Write::write_all(&mut zip, b"out").unwrap();
        zip.finish().unwrap();

        let err = Fmu::open(&path).unwrap_err();
        assert!(matches!(err, ImportError::Unpack { .. }), "{link}: {err:?}");
        assert!(
            err.to_string().contains(&path.display().to_string()),
            "{err}"
        );
        assert!(!outside.path().join("escaped.txt").exists(), "{link}");
        let tmp = std::env::temp_dir();
        for above in tmp.ancestors().take(3) {
            assert!(
                !above.join("escaped.txt").exists(),
                "{link}: {}",
                above.display()
            );
        }
    }
}

const FORCES: [u32; 6] = [1, 2, 3, 4, 5, 6];
const XS: [u32; 6] = [11, 12, 13, 14, 15, 16];

#[test]
fn opens_and_exposes_description_and_resources() {
    let (_dir, fmu) = open();
    assert_eq!(fmu.model_description().model_name, "MiniPlatform");
    let uri = fmu.resource_uri();
    assert!(
        uri.starts_with("file:///") && uri.ends_with("/resources/"),
        "{uri}"
    );
    let table = fmu.unpacked_dir().join("resources/table.csv");
    assert_eq!(std::fs::read_to_string(table).unwrap(), "t,x\n0,1\n");
}

#[test]
fn instantiate_passes_guid_and_resource_uri() {
    let (_dir, fmu) = open();
    let inst = fmu.instantiate("plant", true).unwrap();
    assert_eq!(inst.name(), "plant");
    let log = inst.take_log();
    assert_eq!(log.len(), 1, "{log:?}");
    assert_eq!(log[0].status, Status::Ok);
    assert_eq!(log[0].category, "logAll");
    assert_eq!(
        log[0].message,
        format!("resources at {}", fmu.resource_uri())
    );
    assert!(inst.take_log().is_empty(), "take_log drains");
}

#[test]
fn wrong_guid_fails_with_the_fmus_message() {
    let dir = tempfile::tempdir().unwrap();
    let xml = import_support::MODEL_DESCRIPTION.replacen(
        "{6f1c3a52-8d0e-4b7a-9e21-3c5d7a1b2f90}",
        "{00000000-0000-0000-0000-000000000000}",
        1,
    );
    let fmu = Fmu::open(import_support::dummy_fmu_with(dir.path(), &xml)).unwrap();
    let err = fmu
        .instantiate("plant", false)
        .expect_err("instantiation must fail");
    assert!(matches!(err, ImportError::Instantiate { .. }), "{err:?}");
    assert_eq!(
        err.to_string(),
        "fmi2Instantiate failed for instance 'plant': [fmi2Error] logStatusError: wrong GUID \
         {00000000-0000-0000-0000-000000000000}, expected {6f1c3a52-8d0e-4b7a-9e21-3c5d7a1b2f90}"
    );
}

#[test]
fn simulation_round_trip() {
    let (_dir, fmu) = open();
    let mut inst = fmu.instantiate("plant", false).unwrap();
    inst.take_log();
    assert_eq!(
        inst.setup_experiment(Some(1e-6), 0.0, Some(1.0)).unwrap(),
        Status::Ok
    );
    inst.enter_initialization_mode().unwrap();
    let long = inst.take_log();
    assert_eq!(long.len(), 1);
    assert_eq!(
        long[0].message.len(),
        "long:".len() + 2000 + ":end".len(),
        "long messages are not truncated"
    );
    assert!(long[0].message.starts_with("long:xxx") && long[0].message.ends_with("xxx:end"));
    inst.exit_initialization_mode().unwrap();

    inst.set_real(&FORCES, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
        .unwrap();
    for n in 0..10 {
        inst.do_step(f64::from(n) * 0.001, 0.001, true).unwrap();
    }
    let mut x = [0.0; 6];
    inst.get_real(&XS, &mut x).unwrap();
    for (i, xi) in x.iter().enumerate() {
        let expected = 0.01 * (i as f64 + 1.0);
        assert!(
            (xi - expected).abs() < 1e-12,
            "x[{}] = {xi}, expected {expected}",
            i + 1
        );
    }
    let mut total = [0.0];
    inst.get_real(&[25], &mut total).unwrap();
    assert_eq!(total[0], 9.84);
    assert!((inst.last_successful_time().unwrap() - 0.01).abs() < 1e-15);
    assert!(!inst.is_terminated().unwrap());

    inst.set_integer(&[24], &[5]).unwrap();
    let mut trials = [0];
    inst.get_integer(&[24], &mut trials).unwrap();
    assert_eq!(trials, [5]);

    // More booleans than one stack chunk, to cross the chunk boundary.
    let vrs: Vec<u32> = (0..100).map(|k| k % 32).collect();
    let values: Vec<bool> = (0..100).map(|k| k % 3 == 0).collect();
    inst.set_boolean(&vrs[..32], &values[..32]).unwrap();
    let mut back = vec![false; 100];
    inst.get_boolean(&vrs, &mut back).unwrap();
    for k in 0..100 {
        assert_eq!(back[k], values[k % 32], "bool {k}");
    }

    assert_eq!(inst.get_string(&[26]).unwrap(), ["mini"]);
    inst.set_string(&[26], &["hello"]).unwrap();
    assert_eq!(inst.take_log()[0].message, "string 26 = hello");

    inst.terminate().unwrap();
    inst.reset().unwrap();
    assert_eq!(inst.last_successful_time().unwrap(), 0.0);
}

#[test]
fn warnings_are_ok_and_logged() {
    let (_dir, fmu) = open();
    let mut inst = fmu.instantiate("plant", false).unwrap();
    inst.take_log();
    assert_eq!(inst.set_real(&[1], &[f64::NAN]).unwrap(), Status::Warning);
    let log = inst.take_log();
    assert_eq!(log.len(), 1);
    assert_eq!(
        (log[0].status, log[0].message.as_str()),
        (Status::Warning, "NaN for vr 1 ignored")
    );
}

#[test]
fn errors_name_function_instance_status_and_messages() {
    let (_dir, fmu) = open();
    let mut inst = fmu.instantiate("controller", false).unwrap();
    // A warning logged by an earlier call stays in the log, out of the next call's error.
    assert_eq!(inst.set_real(&[1], &[f64::NAN]).unwrap(), Status::Warning);
    let err = inst.do_step(0.5, -0.001, true).unwrap_err();
    match &err {
        ImportError::Call {
            function,
            instance,
            status,
            messages,
        } => {
            assert_eq!(
                (*function, instance.as_str(), *status),
                ("fmi2DoStep", "controller", Status::Error)
            );
            assert_eq!(
                messages.len(),
                1,
                "only what was logged during the call: {messages:?}"
            );
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        err.to_string(),
        "fmi2DoStep on instance 'controller' returned fmi2Error: [fmi2Error] logStatusError: invalid step size -0.001 at t=0.5"
    );

    let mut x = [0.0];
    let err = inst.get_real(&[99], &mut x).unwrap_err();
    assert!(
        err.to_string()
            .starts_with("fmi2GetReal on instance 'controller' returned fmi2Error"),
        "{err}"
    );

    let err = inst.get_integer(&[999], &mut [0]).unwrap_err();
    assert!(
        matches!(err, ImportError::InvalidStatus { raw: 7, .. }),
        "{err:?}"
    );
    assert!(err.to_string().contains(
        "fmi2GetInteger on instance 'controller' returned 7, which is not a valid fmi2Status"
    ));

    let err = inst
        .get_directional_derivative(&[11], &[1], &[1.0], &mut [0.0])
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("directional derivatives are not provided"),
        "{err}"
    );
}

#[test]
fn slice_length_mismatch_is_an_error_not_a_panic() {
    let (_dir, fmu) = open();
    let mut inst = fmu.instantiate("plant", false).unwrap();
    let err = inst.set_real(&[1, 2], &[1.0]).unwrap_err();
    assert_eq!(
        err.to_string(),
        "fmi2SetReal on instance 'plant': 2 value references but 1 values"
    );
    assert!(inst.get_real(&[1], &mut [0.0; 2]).is_err());
    assert!(inst.set_integer(&[1], &[]).is_err());
    assert!(inst.get_boolean(&[1, 2, 3], &mut [false]).is_err());
    assert!(inst.set_string(&[26], &["a\0b"]).is_err());
}

#[test]
fn fmu_states_get_set_serialize_and_free() {
    let (_dir, fmu) = open();
    let mut inst = fmu.instantiate("plant", false).unwrap();
    inst.set_real(&[1], &[1.0]).unwrap();
    inst.do_step(0.0, 1.0, false).unwrap();
    let snapshot = inst.get_fmu_state().unwrap();
    inst.do_step(1.0, 1.0, false).unwrap();
    let mut x = [0.0];
    inst.get_real(&[11], &mut x).unwrap();
    assert_eq!(x[0], 2.0);

    inst.set_fmu_state(&snapshot).unwrap();
    inst.get_real(&[11], &mut x).unwrap();
    assert_eq!(x[0], 1.0);
    assert_eq!(inst.last_successful_time().unwrap(), 1.0);

    let bytes = inst.serialize_fmu_state(&snapshot).unwrap();
    inst.do_step(1.0, 5.0, false).unwrap();
    let restored = inst.deserialize_fmu_state(&bytes).unwrap();
    inst.set_fmu_state(&restored).unwrap();
    inst.get_real(&[11], &mut x).unwrap();
    assert_eq!(x[0], 1.0);

    let err = inst.deserialize_fmu_state(&bytes[1..]).unwrap_err();
    assert!(err.to_string().contains("serialized state has"), "{err}");

    // The dummy counts freed states in Integer vr 30.
    let mut freed = [0];
    inst.get_integer(&[30], &mut freed).unwrap();
    let before = freed[0];
    drop(snapshot);
    drop(restored);
    inst.get_integer(&[30], &mut freed).unwrap();
    assert_eq!(
        freed[0],
        before + 2,
        "fmi2FreeFMUstate ran for each dropped state"
    );
}

#[test]
fn states_are_bound_to_their_instance_and_may_outlive_it() {
    let (_dir, fmu) = open();
    let mut a = fmu.instantiate("a", false).unwrap();
    let mut b = fmu.instantiate("b", false).unwrap();
    let state_a = a.get_fmu_state().unwrap();
    let err = b.set_fmu_state(&state_a).unwrap_err();
    assert_eq!(
        err.to_string(),
        "fmi2SetFMUstate on instance 'b': the FMU state belongs to instance 'a'"
    );
    drop(a);
    // Freed against the still-live component; FreeInstance follows.
    drop(state_a);
}

#[test]
fn instances_outlive_the_fmu_handle() {
    let (_dir, fmu) = open();
    let unpacked = fmu.unpacked_dir().to_path_buf();
    let mut inst = fmu.instantiate("plant", false).unwrap();
    drop(fmu);
    assert!(unpacked.exists(), "files stay while an instance lives");
    inst.do_step(0.0, 0.001, false).unwrap();
    drop(inst);
    assert!(
        !unpacked.exists(),
        "the temporary directory is removed with the last user"
    );
}

/// Dropping an instance frees it in the FMU (fmi2FreeInstance): a sweep makes thousands,
/// and each would otherwise stay allocated inside the FMU.
#[test]
fn dropping_an_instance_frees_it_in_the_fmu() {
    let (dir, fmu) = open();
    let marker = dir.path().join("freed");
    let inst = fmu
        .instantiate(&format!("mark:{}", marker.display()), false)
        .unwrap();
    assert!(!marker.exists());
    drop(inst);
    assert!(marker.exists(), "fmi2FreeInstance was not called");
}

/// The log keeps the last `MAX_LOG_RECORDS` messages and says how many older ones it let go.
#[test]
fn a_full_log_says_how_many_messages_it_dropped() {
    let (_dir, fmu) = open();
    let mut inst = fmu.instantiate("chatty", false).unwrap();
    inst.take_log();
    for _ in 0..fmi2_import::MAX_LOG_RECORDS + 5 {
        assert_eq!(inst.set_real(&[1], &[f64::NAN]).unwrap(), Status::Warning);
    }
    let log = inst.take_log();
    assert_eq!(log.len(), fmi2_import::MAX_LOG_RECORDS + 1);
    assert_eq!(
        log[0].message,
        format!(
            "5 earlier log messages were dropped (limit {})",
            fmi2_import::MAX_LOG_RECORDS
        )
    );
}

/// Status queries the FMU refuses (fmi2Discard: it has no such status) are errors, not
/// an empty answer.
#[test]
fn refused_status_queries_are_errors() {
    let (_dir, fmu) = open();
    let mut inst = fmu.instantiate("plant", false).unwrap();
    let discarded = |r: Result<String, ImportError>| {
        matches!(
            r,
            Err(ImportError::Call {
                status: Status::Discard,
                ..
            })
        )
    };
    assert!(discarded(inst.pending_status()));
    assert!(discarded(inst.integer_status(0).map(|v| v.to_string())));
}

/// fmi2Terminated as the FMU reports it: this one asks to end from t = 100 s on.
#[test]
fn the_fmus_request_to_terminate_is_read() {
    let (_dir, fmu) = open();
    let mut inst = fmu.instantiate("plant", false).unwrap();
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    inst.do_step(0.0, 50.0, true).unwrap();
    assert!(!inst.is_terminated().unwrap());
    inst.do_step(50.0, 50.0, true).unwrap();
    assert!(inst.is_terminated().unwrap());
}

/// A binary whose fmi2GetVersion is not "2.0" is refused on open, naming what it said: it
/// is another FMI version's, and its functions take other arguments.
#[test]
fn a_binary_of_another_fmi_version_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let library = dir.path().join("MiniPlatform.so");
    import_support::compile(&library, &[r#"-DDUMMY_VERSION="1.0""#]);
    let path = dir.path().join("MiniPlatform.fmu");
    fmu_build::write_fmu(
        &path,
        import_support::MODEL_DESCRIPTION,
        Some(&library),
        &[],
    )
    .unwrap();
    let err = Fmu::open(&path).unwrap_err();
    assert!(
        matches!(&err, ImportError::Version { function: "fmi2GetVersion", found, .. } if found == "1.0"),
        "{err:?}"
    );
    assert!(err.is_binary_problem());
}
