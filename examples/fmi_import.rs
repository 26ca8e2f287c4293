//! Import the packaged FMU from Rust and run the paper case: adaptive dual-pump scheme,
//! v_ref = 0.05 m/s from rest, 12 kN load, 20 s, 0.01 s communication steps.
//!
//! ```text
//! cargo build --release                        # builds target/fmu/TbmThrust.fmu
//! cargo run --release --example fmi_import [-- path/to/TbmThrust.fmu]
//! ```
//!
//! It unzips the FMU, loads `binaries/<platform>/tbm_thrust.<ext>` with libloading, reads
//! the GUID and value references from modelDescription.xml and drives the FMI 2.0
//! Co-Simulation calls an importer makes: fmi2Instantiate, fmi2SetupExperiment, setting
//! start values, fmi2Enter/ExitInitializationMode, then fmi2DoStep + fmi2GetReal per step.

use libloading::{Library, Symbol};
use std::error::Error;
use std::ffi::{c_char, c_int, c_uint, c_void, CStr, CString};
use std::path::{Path, PathBuf};

type Component = *mut c_void;
type Status = c_int;
const OK: Status = 0;
const CO_SIMULATION: c_int = 1;

/// fmi2CallbackFunctions.
#[repr(C)]
struct Callbacks {
    logger:
        unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char, ...),
    allocate_memory: *const c_void,
    free_memory: *const c_void,
    step_finished: *const c_void,
    component_environment: *mut c_void,
}

/// Prints what the FMU logs. This FMU always calls its logger with the format "%s" and the
/// message as the one variadic argument; stable Rust cannot define a variadic function, so
/// this one takes that argument as a sixth parameter (the same registers on x86_64 and
/// aarch64 Linux and on Windows x64).
unsafe extern "C" fn print_log(
    _env: *mut c_void,
    name: *const c_char,
    status: c_int,
    category: *const c_char,
    _format: *const c_char,
    message: *const c_char,
) {
    let s = |p: *const c_char| CStr::from_ptr(p).to_string_lossy();
    eprintln!(
        "[{} {} status={status}] {}",
        s(name),
        s(category),
        s(message)
    );
}

/// Outputs at one communication point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub time: f64,
    pub x: f64,
    pub v: f64,
    pub p: f64,
    pub q1: f64,
    pub q2: f64,
    pub e_x: f64,
}

const OUTPUTS: [&str; 6] = ["x", "v", "p", "Q1", "Q2", "e_x"];

/// `valueReference` of the variable `name` in modelDescription.xml.
fn value_reference(xml: &str, name: &str) -> Result<c_uint, Box<dyn Error>> {
    let at = xml
        .find(&format!("name=\"{name}\""))
        .ok_or(format!("no variable {name}"))?;
    let rest = &xml[at..];
    let start = rest.find("valueReference=\"").ok_or("no valueReference")? + 16;
    let end = rest[start..].find('"').ok_or("bad valueReference")?;
    Ok(rest[start..start + end].parse()?)
}

fn attribute<'a>(xml: &'a str, key: &str) -> Result<&'a str, Box<dyn Error>> {
    let start = xml
        .find(&format!(" {key}=\""))
        .ok_or(format!("no {key} attribute"))?
        + key.len()
        + 3;
    let end = xml[start..].find('"').ok_or("bad attribute")?;
    Ok(&xml[start..start + end])
}

/// Unzips the FMU into a fresh directory; returns it and its shared library's path.
fn unpack(fmu: &Path) -> Result<(PathBuf, PathBuf), Box<dyn Error>> {
    let dir = std::env::temp_dir().join(format!("tbm-thrust-example-{}", std::process::id()));
    zip::ZipArchive::new(std::fs::File::open(fmu)?)?.extract(&dir)?;
    let (platform, ext) = match std::env::consts::OS {
        "windows" => ("win64", "dll"),
        "macos" => ("darwin64", "dylib"),
        _ => ("linux64", "so"),
    };
    let library = dir
        .join("binaries")
        .join(platform)
        .join(format!("tbm_thrust.{ext}"));
    Ok((dir, library))
}

fn check(status: Status, call: &str) -> Result<(), Box<dyn Error>> {
    if status == OK {
        Ok(())
    } else {
        Err(format!("{call} returned status {status}").into())
    }
}

/// Runs the FMU with constant `v_ref` [m/s] and `load` [N] for `duration` [s] in steps of
/// `step` [s]; returns the outputs at t = 0 and after every step.
pub fn run_paper_case(
    fmu: &Path,
    v_ref: f64,
    load: f64,
    duration: f64,
    step: f64,
) -> Result<Vec<Sample>, Box<dyn Error>> {
    let (dir, library_path) = unpack(fmu)?;
    let xml = std::fs::read_to_string(dir.join("modelDescription.xml"))?;
    let guid = CString::new(attribute(&xml, "guid")?)?;
    let inputs = [
        value_reference(&xml, "v_ref")?,
        value_reference(&xml, "F_L")?,
    ];
    let outputs: Vec<c_uint> = OUTPUTS
        .iter()
        .map(|n| value_reference(&xml, n))
        .collect::<Result<_, _>>()?;
    let resources = CString::new(format!("file://{}/resources", dir.display()))?;

    // SAFETY: the FMI 2.0 functions of the FMU, called with the arguments the standard specifies.
    unsafe {
        let lib = Library::new(&library_path)?;
        let instantiate: Symbol<
            unsafe extern "C" fn(
                *const c_char,
                c_int,
                *const c_char,
                *const c_char,
                *const Callbacks,
                c_int,
                c_int,
            ) -> Component,
        > = lib.get(b"fmi2Instantiate\0")?;
        let setup: Symbol<unsafe extern "C" fn(Component, c_int, f64, f64, c_int, f64) -> Status> =
            lib.get(b"fmi2SetupExperiment\0")?;
        let enter: Symbol<unsafe extern "C" fn(Component) -> Status> =
            lib.get(b"fmi2EnterInitializationMode\0")?;
        let exit: Symbol<unsafe extern "C" fn(Component) -> Status> =
            lib.get(b"fmi2ExitInitializationMode\0")?;
        let set_real: Symbol<
            unsafe extern "C" fn(Component, *const c_uint, usize, *const f64) -> Status,
        > = lib.get(b"fmi2SetReal\0")?;
        let get_real: Symbol<
            unsafe extern "C" fn(Component, *const c_uint, usize, *mut f64) -> Status,
        > = lib.get(b"fmi2GetReal\0")?;
        let do_step: Symbol<unsafe extern "C" fn(Component, f64, f64, c_int) -> Status> =
            lib.get(b"fmi2DoStep\0")?;
        let terminate: Symbol<unsafe extern "C" fn(Component) -> Status> =
            lib.get(b"fmi2Terminate\0")?;
        let free: Symbol<unsafe extern "C" fn(Component)> = lib.get(b"fmi2FreeInstance\0")?;

        type Logger = unsafe extern "C" fn(
            *mut c_void,
            *const c_char,
            c_int,
            *const c_char,
            *const c_char,
            ...
        );
        let logger =
            std::mem::transmute::<unsafe extern "C" fn(_, _, _, _, _, _), Logger>(print_log);
        let callbacks = Callbacks {
            logger,
            allocate_memory: std::ptr::null(),
            free_memory: std::ptr::null(),
            step_finished: std::ptr::null(),
            component_environment: std::ptr::null_mut(),
        };
        let name = CString::new("thrust_cylinder")?;
        let c = instantiate(
            name.as_ptr(),
            CO_SIMULATION,
            guid.as_ptr(),
            resources.as_ptr(),
            &callbacks,
            0,
            0,
        );
        if c.is_null() {
            return Err("fmi2Instantiate failed".into());
        }
        let read = |time: f64| -> Result<Sample, Box<dyn Error>> {
            let mut y = [0.0; OUTPUTS.len()];
            check(
                get_real(c, outputs.as_ptr(), outputs.len(), y.as_mut_ptr()),
                "fmi2GetReal",
            )?;
            Ok(Sample {
                time,
                x: y[0],
                v: y[1],
                p: y[2],
                q1: y[3],
                q2: y[4],
                e_x: y[5],
            })
        };
        let n = (duration / step).round() as usize;
        let run = || -> Result<Vec<Sample>, Box<dyn Error>> {
            check(
                setup(c, 0, 0.0, 0.0, 1, n as f64 * step),
                "fmi2SetupExperiment",
            )?;
            check(
                set_real(c, inputs.as_ptr(), 2, [v_ref, load].as_ptr()),
                "fmi2SetReal",
            )?;
            check(enter(c), "fmi2EnterInitializationMode")?;
            check(exit(c), "fmi2ExitInitializationMode")?;
            // Communication points on the grid k * step (as FMPy does), not accumulated sums.
            let mut samples = vec![read(0.0)?];
            for k in 0..n {
                let (t, next) = (k as f64 * step, (k + 1) as f64 * step);
                check(do_step(c, t, next - t, 1), "fmi2DoStep")?;
                samples.push(read(next)?);
            }
            check(terminate(c), "fmi2Terminate")?;
            Ok(samples)
        };
        let result = run();
        free(c);
        drop(lib);
        let _ = std::fs::remove_dir_all(&dir);
        result
    }
}

fn main() -> Result<(), Box<dyn Error>> {
    let fmu = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(tbm_thrust_fmu::FMU_PATH));
    let samples = run_paper_case(&fmu, 0.05, 12_000.0, 20.0, 0.01)?;
    println!(
        "{:>6} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}",
        "t [s]", "x [mm]", "v [mm/s]", "p [MPa]", "Q1 [L/min]", "Q2 [L/min]", "e_x [mm]"
    );
    for s in samples.iter().step_by(100) {
        println!(
            "{:>6.2} {:>10.3} {:>10.3} {:>10.4} {:>10.3} {:>10.3} {:>10.4}",
            s.time,
            s.x * 1e3,
            s.v * 1e3,
            s.p * 1e-6,
            s.q1 * 6e4,
            s.q2 * 6e4,
            s.e_x * 1e3
        );
    }
    let peak = samples.iter().map(|s| s.e_x.abs()).fold(0.0, f64::max);
    println!(
        "peak |e_x| = {:.4} mm over {} communication steps",
        peak * 1e3,
        samples.len() - 1
    );
    Ok(())
}
