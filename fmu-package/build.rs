//! Packages `target/fmu/TbmThrust.fmu` (FMI 2.0 Co-Simulation).
//!
//! A build script runs before its own crate is compiled, so the FMU cannot be packaged by
//! the `tbm-thrust` crate itself. This separate crate's build script instead runs a nested
//! `cargo build --release --lib -p tbm-thrust`:
//! - in its own target directory (`<target>/fmu-build`), so it never waits for the lock the
//!   outer cargo holds on `<target>/<profile>`;
//! - with the inherited cargo/rustc environment scrubbed (`CARGO_TARGET_DIR`, `RUSTFLAGS`,
//!   `CARGO_ENCODED_RUSTFLAGS`, `RUSTC_WRAPPER` set by clippy, ...), so the library is always
//!   a plain release build whatever command started the outer build;
//! - with `--message-format=json`, from which it takes the cdylib's file name and the out
//!   dir of tbm-thrust's build script, which holds the generated `modelDescription.xml`.
//!
//! On x86_64 Linux the nested build links against glibc 2.17 (the manylinux2014 baseline)
//! with `cargo zigbuild --target x86_64-unknown-linux-gnu.2.17`, so the FMU loads on RHEL 7+,
//! Ubuntu 14.04+ and the like, not only on a machine as new as the build machine. How the
//! Linux binary is built is chosen by `TBM_FMU_LINUX_BUILD`:
//! - `auto` (default): zigbuild when `cargo-zigbuild` and zig are installed
//!   (`scripts/install-zig.sh`), else a plain build with a warning;
//! - `zigbuild`: zigbuild or fail (what `scripts/test.sh` sets);
//! - `native`: a plain build, needing the build machine's glibc.
//!
//! The route taken is recorded (`tbm_thrust_fmu::LINUX_BUILD`, the documentation page), and
//! `tests/fmu_package.rs` checks the binary's versioned glibc symbols against it.
//!
//! It then zips `modelDescription.xml`, `binaries/<platform>/tbm_thrust.<ext>` and
//! `documentation/index.html` (generated from the modelDescription) into the FMU, written
//! atomically. No recursion: tbm-thrust does not depend on this crate (only its tests do,
//! as a dev-dependency, which a `--lib` build never builds).

use quick_xml::events::Event;
use quick_xml::Reader;
use std::env;
use std::ffi::OsString;
use std::fmt::Write as _;
use std::fs;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const MODEL_IDENTIFIER: &str = "tbm_thrust";
const FMU_NAME: &str = "TbmThrust.fmu";

fn main() {
    let manifest_dir = PathBuf::from(env::var("CARGO_MANIFEST_DIR").unwrap());
    let root = manifest_dir
        .parent()
        .expect("fmu-package lives in the workspace root")
        .to_path_buf();
    for watched in [
        "src",
        "modelDescription",
        "build.rs",
        "Cargo.toml",
        "Cargo.lock",
    ] {
        println!("cargo:rerun-if-changed={}", root.join(watched).display());
    }
    println!("cargo:rerun-if-changed=build.rs");

    for var in [
        "TBM_FMU_LINUX_BUILD",
        "CARGO_ZIGBUILD_PYTHON_PATH",
        "CARGO_ZIGBUILD_ZIG_PATH",
    ] {
        println!("cargo:rerun-if-env-changed={var}");
    }
    let zig_stamp = root.join(ZIG_TOOLS).join(ZIG_STAMP);
    if zig_stamp.is_file() {
        println!("cargo:rerun-if-changed={}", zig_stamp.display());
    }

    let target = env::var("TARGET").unwrap();
    let target_dir = outer_target_dir(&PathBuf::from(env::var("OUT_DIR").unwrap()), &target);
    let (platform, ext) = platform_folder(&target);
    let route = linux_route(&root, &target);
    let built = nested_build(&root, &target_dir.join("fmu-build"), &target, &route);

    let fmu = target_dir.join("fmu").join(FMU_NAME);
    let library = format!("{MODEL_IDENTIFIER}.{ext}");
    package(&built, &fmu, &platform, &library, &route.describe());

    println!("cargo:rustc-env=TBM_THRUST_FMU_PATH={}", fmu.display());
    println!("cargo:rustc-env=TBM_THRUST_FMU_PLATFORM={platform}");
    println!("cargo:rustc-env=TBM_THRUST_FMU_LIBRARY={library}");
    println!(
        "cargo:rustc-env=TBM_THRUST_FMU_LINUX_BUILD={}",
        route.describe()
    );
    println!(
        "cargo:rustc-env=TBM_THRUST_FMU_GLIBC={}",
        match route {
            Route::Zig { .. } => GLIBC_BASELINE,
            _ => "",
        }
    );
}

/// The oldest glibc the portable Linux binary needs (manylinux2014).
const GLIBC_BASELINE: &str = "2.17";
/// Where `scripts/install-zig.sh` puts a Python venv holding the `ziglang` wheel.
const ZIG_TOOLS: &str = ".tools/zig";
/// Written by `scripts/install-zig.sh` when the venv is complete.
const ZIG_STAMP: &str = "ziglang.installed";

/// How the nested build makes the library.
enum Route {
    /// `cargo zigbuild --target <triple>.2.17`, with the zig found by cargo-zigbuild (the
    /// environment may name a Python with `ziglang`; `python` is the one of ZIG_TOOLS if any).
    Zig { python: Option<PathBuf> },
    /// A plain `cargo build` on x86_64 Linux: the binary needs the build machine's glibc.
    /// `reason` says why (chosen, or zig missing in `auto`).
    Native { reason: String },
    /// Not x86_64 Linux: a plain (cross) build; the glibc question does not arise.
    Other,
}

impl Route {
    fn describe(&self) -> String {
        match self {
            Route::Zig { .. } => format!(
                "cargo zigbuild x86_64-unknown-linux-gnu.{GLIBC_BASELINE} (needs glibc >= {GLIBC_BASELINE})"
            ),
            Route::Native { reason } => {
                format!("native cargo build (needs the build machine's glibc; {reason})")
            }
            Route::Other => "cargo build".into(),
        }
    }
}

/// The route for `triple`, from `TBM_FMU_LINUX_BUILD` and what is installed.
fn linux_route(root: &Path, triple: &str) -> Route {
    if triple != "x86_64-unknown-linux-gnu" {
        return Route::Other;
    }
    let choice = env::var("TBM_FMU_LINUX_BUILD").unwrap_or_else(|_| "auto".into());
    let python = root.join(ZIG_TOOLS).join("bin").join("python");
    let python =
        (root.join(ZIG_TOOLS).join(ZIG_STAMP).is_file() && python.is_file()).then_some(python);
    let missing = || zig_missing(python.as_deref());
    match choice.as_str() {
        "native" => Route::Native {
            reason: "TBM_FMU_LINUX_BUILD=native".into(),
        },
        "zigbuild" => match missing() {
            None => Route::Zig { python },
            Some(why) => panic!(
                "TBM_FMU_LINUX_BUILD=zigbuild but {why}; run scripts/install-zig.sh \
                 (cargo-zigbuild + the ziglang wheel) or set TBM_FMU_LINUX_BUILD=native"
            ),
        },
        "auto" | "" => match missing() {
            None => Route::Zig { python },
            Some(why) => {
                println!(
                    "cargo:warning=FMU binary built natively, NOT portable to older glibc: {why} \
                     (run scripts/install-zig.sh for a glibc {GLIBC_BASELINE} build)"
                );
                Route::Native {
                    reason: format!("TBM_FMU_LINUX_BUILD=auto and {why}"),
                }
            }
        },
        other => panic!("TBM_FMU_LINUX_BUILD={other:?}: expected auto, zigbuild or native"),
    }
}

/// Why `cargo zigbuild` cannot run here, or None if it can.
fn zig_missing(python: Option<&Path>) -> Option<String> {
    let cargo = env::var_os("CARGO").unwrap_or_else(|| OsString::from("cargo"));
    let ok = |cmd: &mut Command| {
        cmd.stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    if !ok(Command::new(&cargo).args(["zigbuild", "--help"])) {
        return Some("cargo-zigbuild is not installed".into());
    }
    let zig_found = match python {
        Some(py) => ok(Command::new(py).args(["-m", "ziglang", "version"])),
        None => {
            env::var_os("CARGO_ZIGBUILD_PYTHON_PATH")
                .is_some_and(|py| ok(Command::new(py).args(["-m", "ziglang", "version"])))
                || ok(Command::new(
                    env::var_os("CARGO_ZIGBUILD_ZIG_PATH").unwrap_or_else(|| "zig".into()),
                )
                .arg("version"))
                || ok(Command::new("python3").args(["-m", "ziglang", "version"]))
        }
    };
    (!zig_found).then(|| format!("no zig found (neither {ZIG_TOOLS} nor zig / python3 -m ziglang)"))
}

/// The outer build's target directory: OUT_DIR is `<target>[/<triple>]/<profile>/build/<pkg>-<hash>/out`.
fn outer_target_dir(out_dir: &Path, triple: &str) -> PathBuf {
    let profile_dir = out_dir
        .ancestors()
        .nth(3)
        .expect("OUT_DIR has the cargo layout");
    let parent = profile_dir.parent().expect("profile dir has a parent");
    if parent.file_name().is_some_and(|n| n == triple) {
        parent
            .parent()
            .expect("triple dir has a parent")
            .to_path_buf()
    } else {
        parent.to_path_buf()
    }
}

/// FMI 2.0 platform folder and shared-library extension for a Rust target triple.
fn platform_folder(triple: &str) -> (String, &'static str) {
    let bits64 = triple.starts_with("x86_64") || triple.starts_with("aarch64");
    let bits = if bits64 { "64" } else { "32" };
    if triple.contains("windows") {
        (format!("win{bits}"), "dll")
    } else if triple.contains("apple") {
        (format!("darwin{bits}"), "dylib")
    } else if triple.contains("linux") && !triple.starts_with("aarch64") {
        (format!("linux{bits}"), "so")
    } else {
        // FMI 2.0 names no folder for other platforms; use the FMI 3.0 platform tuple.
        let arch = triple.split('-').next().unwrap_or(triple);
        println!(
            "cargo:warning=FMI 2.0 defines no platform folder for {triple}; using {arch}-linux"
        );
        (format!("{arch}-linux"), "so")
    }
}

/// What the nested build produced.
struct Built {
    library: PathBuf,
    model_description: PathBuf,
}

/// `cargo build --release --lib -p tbm-thrust` in its own target dir with a clean environment.
fn nested_build(root: &Path, target_dir: &Path, triple: &str, route: &Route) -> Built {
    let cargo = env::var_os("CARGO").unwrap_or_else(|| OsString::from("cargo"));
    let mut cmd = Command::new(cargo);
    cmd.args([
        if matches!(route, Route::Zig { .. }) {
            "zigbuild"
        } else {
            "build"
        },
        "--release",
        "--lib",
        "--locked",
        "-p",
        "tbm-thrust",
    ])
    .arg("--manifest-path")
    .arg(root.join("Cargo.toml"))
    .arg("--target-dir")
    .arg(target_dir)
    .arg("--message-format=json-render-diagnostics")
    .current_dir(root)
    .stdin(Stdio::null())
    .stdout(Stdio::piped())
    .stderr(Stdio::inherit());
    if let Route::Zig { .. } = route {
        cmd.arg("--target")
            .arg(format!("{triple}.{GLIBC_BASELINE}"));
    } else if triple != env::var("HOST").unwrap() {
        cmd.args(["--target", triple]);
    }
    for (key, _) in env::vars_os() {
        if key.to_str().is_some_and(inherited_build_variable) {
            cmd.env_remove(key);
        }
    }
    if let Route::Zig {
        python: Some(python),
    } = route
    {
        cmd.env("CARGO_ZIGBUILD_PYTHON_PATH", python);
    }
    let output = cmd
        .output()
        .expect("run the nested cargo build of tbm-thrust");
    assert!(
        output.status.success(),
        "nested build of tbm-thrust ({}) failed ({}); see its messages above",
        route.describe(),
        output.status
    );
    parse_messages(
        &String::from_utf8_lossy(&output.stdout),
        &root.join("Cargo.toml"),
    )
}

/// Variables cargo sets for a build script (or a user sets for the outer build) that must
/// not leak into the nested build: they would redirect it, change its flags or wrap rustc.
fn inherited_build_variable(key: &str) -> bool {
    const KEEP: &[&str] = &[
        "CARGO_HOME",
        "CARGO_MAKEFLAGS",
        "CARGO_NET_",
        "CARGO_HTTP_",
        "CARGO_REGISTRIES_",
        "CARGO_REGISTRY_",
        "CARGO_ZIGBUILD_",
    ];
    const DROP: &[&str] = &[
        "CARGO",
        "RUSTFLAGS",
        "RUSTDOCFLAGS",
        "RUSTC",
        "RUSTDOC",
        "RUSTC_WRAPPER",
        "RUSTC_WORKSPACE_WRAPPER",
        "RUSTC_LINKER",
        "OUT_DIR",
        "TARGET",
        "HOST",
        "PROFILE",
        "OPT_LEVEL",
        "DEBUG",
        "NUM_JOBS",
        "CLIPPY_ARGS",
    ];
    if KEEP.iter().any(|k| key.starts_with(k)) {
        return false;
    }
    DROP.contains(&key)
        || key.starts_with("CARGO_")
        || key.starts_with("__CARGO")
        || key.starts_with("__CLIPPY")
}

/// Finds the cdylib and the generated modelDescription.xml in cargo's JSON messages.
fn parse_messages(stdout: &str, manifest: &Path) -> Built {
    let mut library = None;
    let mut model_description = None;
    for line in stdout.lines() {
        let Ok(msg) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        match msg["reason"].as_str() {
            Some("compiler-artifact")
                if Path::new(msg["manifest_path"].as_str().unwrap_or("")) == manifest =>
            {
                let files = msg["filenames"]
                    .as_array()
                    .into_iter()
                    .flatten()
                    .filter_map(|f| f.as_str());
                if let Some(lib) = files.map(PathBuf::from).find(|f| is_shared_library(f)) {
                    library = Some(lib);
                }
            }
            Some("build-script-executed") => {
                let xml =
                    Path::new(msg["out_dir"].as_str().unwrap_or("")).join("modelDescription.xml");
                if xml.is_file() {
                    model_description = Some(xml);
                }
            }
            _ => {}
        }
    }
    Built {
        library: library.expect("the nested build reported no tbm-thrust cdylib"),
        model_description: model_description
            .expect("the nested build reported no modelDescription.xml"),
    }
}

fn is_shared_library(path: &Path) -> bool {
    matches!(
        path.extension().and_then(|e| e.to_str()),
        Some("so" | "dll" | "dylib")
    )
}

/// Writes the FMU zip to a temporary file next to `fmu`, then renames it into place.
fn package(built: &Built, fmu: &Path, platform: &str, library: &str, build: &str) {
    let xml = fs::read_to_string(&built.model_description).expect("read modelDescription.xml");
    let binary = fs::read(&built.library).expect("read the tbm-thrust cdylib");
    let docs = documentation(&xml, &format!("binaries/{platform}/{library}: {build}"));
    fs::create_dir_all(fmu.parent().unwrap()).expect("create the fmu directory");
    let partial = fmu.with_extension("fmu.partial");
    let file = fs::File::create(&partial).expect("create the fmu file");
    let mut zip = zip::ZipWriter::new(file);
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .last_modified_time(zip::DateTime::default());
    let entries: [(String, &[u8]); 3] = [
        ("modelDescription.xml".into(), xml.as_bytes()),
        (format!("binaries/{platform}/{library}"), &binary),
        ("documentation/index.html".into(), docs.as_bytes()),
    ];
    for (name, bytes) in entries {
        zip.start_file(name, options).expect("add a zip entry");
        zip.write_all(bytes).expect("write a zip entry");
    }
    zip.finish().expect("finish the fmu zip");
    fs::rename(&partial, fmu).expect("move the fmu into place");
}

/// One model variable as documented.
#[derive(Default)]
struct DocVariable {
    attrs: Vec<(String, String)>,
    start: String,
    unit: String,
}

impl DocVariable {
    fn attr(&self, key: &str) -> &str {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map_or("", |(_, v)| v)
    }
}

/// documentation/index.html: the model's description and its variable table, read from
/// the packaged modelDescription.xml (so the two cannot disagree).
fn documentation(xml: &str, binary: &str) -> String {
    let (title, description, variables) = read_variables(xml);
    let mut html = String::new();
    write!(
        html,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{title}</title></head><body>\n\
         <h1>{title}</h1>\n<p>{description}</p>\n\
         <p>FMI 2.0 Co-Simulation, modelIdentifier <code>{MODEL_IDENTIFIER}</code>. All values in SI units. \
         Fixed parameters can be set only before fmi2ExitInitializationMode; tunable parameters and inputs \
         between communication steps. <code>scheme</code> and <code>controller</code> are enumerations \
         (fmi2SetInteger, values from 1).</p>\n<p>Binary: {binary}.</p>\n<table border=\"1\">\n\
         <tr><th>name</th><th>vr</th><th>causality</th><th>variability</th><th>start</th><th>unit</th><th>description</th></tr>\n"
    )
    .unwrap();
    for v in &variables {
        writeln!(
            html,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            v.attr("name"),
            v.attr("valueReference"),
            v.attr("causality"),
            v.attr("variability"),
            v.start,
            v.unit,
            v.attr("description")
        )
        .unwrap();
    }
    html.push_str("</table>\n</body></html>\n");
    html
}

/// (modelName, description, variables) with attribute values still XML-escaped, ready for HTML.
fn read_variables(xml: &str) -> (String, String, Vec<DocVariable>) {
    let mut reader = Reader::from_str(xml);
    let (mut title, mut description, mut variables) = (String::new(), String::new(), Vec::new());
    loop {
        match reader
            .read_event()
            .expect("parse the generated modelDescription.xml")
        {
            Event::Eof => break,
            Event::Start(e) | Event::Empty(e) => {
                let attrs: Vec<(String, String)> = e
                    .attributes()
                    .flatten()
                    .map(|a| {
                        (
                            String::from_utf8_lossy(a.key.as_ref()).into_owned(),
                            String::from_utf8_lossy(&a.value).into_owned(),
                        )
                    })
                    .collect();
                let get = |k: &str| {
                    attrs
                        .iter()
                        .find(|(n, _)| n == k)
                        .map(|(_, v)| v.clone())
                        .unwrap_or_default()
                };
                match e.name().as_ref() {
                    b"fmiModelDescription" => {
                        (title, description) = (get("modelName"), get("description"))
                    }
                    b"ScalarVariable" => variables.push(DocVariable {
                        attrs,
                        ..Default::default()
                    }),
                    b"Real" | b"Enumeration" => {
                        if let Some(v) = variables.last_mut() {
                            (v.start, v.unit) = (get("start"), get("unit"));
                        }
                    }
                    _ => {}
                }
            }
            _ => {}
        }
    }
    (title, description, variables)
}
