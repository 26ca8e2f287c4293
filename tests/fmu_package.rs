//! The packaged FMU (target/fmu/TbmThrust.fmu): its contents, that its library was built
//! from the current source, and that the library exports only the FMI functions and needs
//! nothing beyond the C runtime.

mod common;

use common::fmi2::{packaged, SYMBOLS};
use std::collections::BTreeSet;
use std::ffi::CStr;
use std::path::Path;
use std::process::Command;
use tbm_thrust::fmi::types::FMI2_CO_SIMULATION;
use tbm_thrust::variables::{GUID, MODEL_DESCRIPTION_XML};

fn archive() -> zip::ZipArchive<std::fs::File> {
    zip::ZipArchive::new(std::fs::File::open(tbm_thrust_fmu::FMU_PATH).expect("the FMU exists"))
        .unwrap()
}

#[test]
fn fmu_holds_model_description_binary_and_documentation() {
    let names: BTreeSet<String> = archive().file_names().map(str::to_string).collect();
    let binary = format!(
        "binaries/{}/{}",
        tbm_thrust_fmu::PLATFORM,
        tbm_thrust_fmu::LIBRARY_FILE
    );
    let expected: BTreeSet<String> = [
        "modelDescription.xml",
        binary.as_str(),
        "documentation/index.html",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    assert_eq!(names, expected);
    assert!(Path::new(tbm_thrust_fmu::FMU_PATH).ends_with("target/fmu/TbmThrust.fmu"));
    if cfg!(all(target_os = "linux", target_arch = "x86_64")) {
        assert_eq!(binary, "binaries/linux64/tbm_thrust.so");
    }
    let mut docs = String::new();
    std::io::Read::read_to_string(
        &mut archive().by_name("documentation/index.html").unwrap(),
        &mut docs,
    )
    .unwrap();
    assert!(
        docs.contains("<td>v_ref</td>") && docs.contains("<td>Kp1</td>"),
        "documentation lists the variables"
    );
}

#[test]
fn library_was_built_from_the_current_source() {
    let fmu = packaged();
    assert_eq!(
        fmu.guid(),
        GUID,
        "the FMU is stale: rebuild with `cargo build --release`"
    );
    assert_eq!(fmu.model_description, MODEL_DESCRIPTION_XML);
    let instance = fmu.instantiate("current", FMI2_CO_SIMULATION, GUID, false);
    assert!(
        instance.is_ok(),
        "the packaged library accepts the GUID of the current source"
    );
    let other = "{00000000-0000-0000-0000-000000000000}";
    let log = fmu
        .instantiate("stale", FMI2_CO_SIMULATION, other, false)
        .err()
        .expect("another GUID is refused");
    assert!(
        log.iter()
            .any(|e| e.message.contains("Wrong GUID") && e.message.contains(GUID)),
        "{log:?}"
    );
}

#[test]
fn version_and_platform() {
    let api = &packaged().api;
    let s = |p| unsafe { CStr::from_ptr(p).to_str().unwrap() };
    assert_eq!(s(unsafe { (api.get_version)() }), "2.0");
    assert_eq!(s(unsafe { (api.get_types_platform)() }), "default");
}

/// The library as packaged, unpacked into its own temporary file for nm or ldd.
fn unpacked_library(user: &str) -> tempdir::Unpacked {
    let binary = format!(
        "binaries/{}/{}",
        tbm_thrust_fmu::PLATFORM,
        tbm_thrust_fmu::LIBRARY_FILE
    );
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut archive().by_name(&binary).unwrap(), &mut bytes).unwrap();
    tempdir::Unpacked::new(user, tbm_thrust_fmu::LIBRARY_FILE, &bytes)
}

mod tempdir {
    use std::path::PathBuf;

    /// A file in a fresh temporary directory, removed on drop.
    pub struct Unpacked(pub PathBuf);

    impl Unpacked {
        pub fn new(user: &str, name: &str, bytes: &[u8]) -> Self {
            let dir =
                std::env::temp_dir().join(format!("tbm-thrust-lib-{}-{user}", std::process::id()));
            std::fs::create_dir_all(&dir).unwrap();
            let path = dir.join(name);
            std::fs::write(&path, bytes).unwrap();
            Unpacked(path)
        }
    }

    impl Drop for Unpacked {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(self.0.parent().unwrap());
        }
    }
}

fn tool_output(tool: &str, args: &[&str], lib: &Path) -> String {
    let out = Command::new(tool)
        .args(args)
        .arg(lib)
        .output()
        .unwrap_or_else(|e| panic!("run {tool}: {e}"));
    assert!(
        out.status.success(),
        "{tool} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
#[cfg(target_os = "linux")]
fn library_exports_exactly_the_fmi2_functions() {
    let lib = unpacked_library("nm");
    let nm = tool_output("nm", &["-D", "--defined-only"], &lib.0);
    let exported: BTreeSet<&str> = nm
        .lines()
        .filter_map(|l| l.split_whitespace().nth(2))
        .collect();
    let expected: BTreeSet<&str> = SYMBOLS.iter().copied().collect();
    assert_eq!(exported, expected, "nm -D --defined-only:\n{nm}");
    assert_eq!(
        expected.len(),
        34,
        "the FMI 2.0 common + Co-Simulation API has 34 functions"
    );
}

#[test]
#[cfg(target_os = "linux")]
fn library_needs_only_the_c_runtime() {
    let lib = unpacked_library("ldd");
    let ldd = tool_output("ldd", &[], &lib.0);
    const ALLOWED: &[&str] = &[
        "linux-vdso",
        "libc.so",
        "libm.so",
        "libgcc_s.so",
        "ld-linux",
        "libpthread.so",
        "libdl.so",
        "librt.so",
    ];
    for line in ldd.lines().map(str::trim).filter(|l| !l.is_empty()) {
        assert!(
            ALLOWED.iter().any(|a| line.contains(a)),
            "unexpected shared library dependency: {line}\n{ldd}"
        );
    }
    assert!(ldd.contains("libc.so"), "{ldd}");
}
