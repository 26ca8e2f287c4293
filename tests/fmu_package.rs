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

/// The newest `GLIBC_x.y[.z]` version among the binary's dynamic symbols (`objdump -T`), as
/// numbers, with the symbols that need it.
fn newest_glibc(objdump: &str) -> (Vec<u32>, Vec<String>) {
    let mut newest: (Vec<u32>, Vec<String>) = (vec![0], Vec::new());
    for line in objdump.lines() {
        let Some(at) = line.find("GLIBC_") else {
            continue;
        };
        let version: String = line[at + 6..]
            .chars()
            .take_while(|c| c.is_ascii_digit() || *c == '.')
            .collect();
        let parsed: Vec<u32> = version
            .split('.')
            .map(|n| n.parse().expect("a GLIBC_ version number"))
            .collect();
        let symbol = line.split_whitespace().last().unwrap_or("?").to_string();
        let entry = format!("{symbol}@GLIBC_{version}");
        if parsed > newest.0 {
            newest = (parsed, vec![entry]);
        } else if parsed == newest.0 {
            newest.1.push(entry);
        }
    }
    newest
}

#[test]
#[cfg(all(target_os = "linux", target_arch = "x86_64"))]
fn library_loads_on_glibc_2_17() {
    println!("FMU binary: {}", tbm_thrust_fmu::LINUX_BUILD);
    let lib = unpacked_library("objdump");
    let objdump = tool_output("objdump", &["-T"], &lib.0);
    let (newest, symbols) = newest_glibc(&objdump);
    let shown = newest
        .iter()
        .map(u32::to_string)
        .collect::<Vec<_>>()
        .join(".");
    println!(
        "newest versioned glibc symbol: GLIBC_{shown} ({})",
        symbols.join(", ")
    );
    assert!(
        newest > vec![2, 2],
        "objdump -T shows no GLIBC_ symbol versions; is this a glibc binary?\n{objdump}"
    );
    assert_eq!(
        tbm_thrust_fmu::GLIBC,
        "2.17",
        "the FMU's binary was not built for glibc 2.17 but by: {}. \
         Run scripts/install-zig.sh (cargo-zigbuild + zig), or build with \
         TBM_FMU_LINUX_BUILD=zigbuild to make a missing zig an error. It needs GLIBC_{shown} ({}).",
        tbm_thrust_fmu::LINUX_BUILD,
        symbols.join(", ")
    );
    assert!(
        newest <= vec![2, 17],
        "built with {} but needs GLIBC_{shown}: {}",
        tbm_thrust_fmu::LINUX_BUILD,
        symbols.join(", ")
    );
}

#[test]
fn glibc_versions_are_compared_as_numbers() {
    let dump = "\
0000000000000000      DF *UND*  0000000000000000 (GLIBC_2.2.5) memcpy
0000000000000000      DF *UND*  0000000000000000 (GLIBC_2.14) memcpy
0000000000000000      DF *UND*  0000000000000000 (GLIBC_2.3.4) __sprintf_chk
0000000000000000  w   DF *UND*  0000000000000000  GLIBC_2.9   pipe2";
    let (newest, symbols) = newest_glibc(dump);
    assert_eq!(newest, vec![2, 14]);
    assert_eq!(symbols, vec!["memcpy@GLIBC_2.14"]);
    let (newest, symbols) = newest_glibc(
        "0 DF *UND* 0 (GLIBC_2.34) pthread_key_create\n0 DF *UND* 0 (GLIBC_2.33) stat64",
    );
    assert_eq!(newest, vec![2, 34]);
    assert_eq!(symbols, vec!["pthread_key_create@GLIBC_2.34"]);
}
