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

/// fmi2CallbackLogger.
type Logger =
    unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char, ...);

/// fmi2CallbackFunctions.
#[repr(C)]
struct Callbacks {
    logger: Logger,
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

/// The FMI 2.0 Co-Simulation functions this importer calls, looked up in the FMU's library.
struct Fmi2<'lib> {
    instantiate: Symbol<
        'lib,
        unsafe extern "C" fn(
            *const c_char,
            c_int,
            *const c_char,
            *const c_char,
            *const Callbacks,
            c_int,
            c_int,
        ) -> Component,
    >,
    setup: Symbol<'lib, unsafe extern "C" fn(Component, c_int, f64, f64, c_int, f64) -> Status>,
    enter: Symbol<'lib, unsafe extern "C" fn(Component) -> Status>,
    exit: Symbol<'lib, unsafe extern "C" fn(Component) -> Status>,
    set_real:
        Symbol<'lib, unsafe extern "C" fn(Component, *const c_uint, usize, *const f64) -> Status>,
    get_real:
        Symbol<'lib, unsafe extern "C" fn(Component, *const c_uint, usize, *mut f64) -> Status>,
    do_step: Symbol<'lib, unsafe extern "C" fn(Component, f64, f64, c_int) -> Status>,
    terminate: Symbol<'lib, unsafe extern "C" fn(Component) -> Status>,
    free: Symbol<'lib, unsafe extern "C" fn(Component)>,
}

impl<'lib> Fmi2<'lib> {
    /// Looks the functions up in `lib`.
    ///
    /// # Safety
    /// `lib` must be an FMI 2.0 Co-Simulation binary: its functions have the signatures the
    /// standard gives them, which the symbols' types state.
    unsafe fn load(lib: &'lib Library) -> Result<Fmi2<'lib>, Box<dyn Error>> {
        Ok(Fmi2 {
            instantiate: lib.get(b"fmi2Instantiate\0")?,
            setup: lib.get(b"fmi2SetupExperiment\0")?,
            enter: lib.get(b"fmi2EnterInitializationMode\0")?,
            exit: lib.get(b"fmi2ExitInitializationMode\0")?,
            set_real: lib.get(b"fmi2SetReal\0")?,
            get_real: lib.get(b"fmi2GetReal\0")?,
            do_step: lib.get(b"fmi2DoStep\0")?,
            terminate: lib.get(b"fmi2Terminate\0")?,
            free: lib.get(b"fmi2FreeInstance\0")?,
        })
    }
}

/// One instance of the FMU, freed (fmi2FreeInstance) when dropped. Every call passes the
/// instance the standard's arguments, so the methods are safe to call.
struct Instance<'a> {
    fmi: &'a Fmi2<'a>,
    component: Component,
    /// The callbacks the FMU keeps a pointer to for the instance's life.
    _callbacks: Box<Callbacks>,
}

impl<'a> Instance<'a> {
    /// fmi2Instantiate as a Co-Simulation slave, visible and without logging.
    fn new(
        fmi: &'a Fmi2<'a>,
        guid: &CStr,
        resources: &CStr,
    ) -> Result<Instance<'a>, Box<dyn Error>> {
        // SAFETY: `print_log` reads the one "%s" argument this FMU passes (see there).
        let logger = unsafe {
            std::mem::transmute::<unsafe extern "C" fn(_, _, _, _, _, _), Logger>(print_log)
        };
        let callbacks = Box::new(Callbacks {
            logger,
            allocate_memory: std::ptr::null(),
            free_memory: std::ptr::null(),
            step_finished: std::ptr::null(),
            component_environment: std::ptr::null_mut(),
        });
        let name = CString::new("thrust_cylinder")?;
        // SAFETY: valid C strings and callbacks that outlive the instance.
        let component = unsafe {
            (fmi.instantiate)(
                name.as_ptr(),
                CO_SIMULATION,
                guid.as_ptr(),
                resources.as_ptr(),
                &*callbacks,
                0,
                0,
            )
        };
        if component.is_null() {
            return Err("fmi2Instantiate failed".into());
        }
        Ok(Instance {
            fmi,
            component,
            _callbacks: callbacks,
        })
    }

    /// fmi2SetupExperiment (no tolerance, from 0 to `stop` [s]), the start values of
    /// `inputs`, and fmi2Enter/ExitInitializationMode.
    fn initialize(
        &self,
        stop: f64,
        inputs: &[c_uint],
        values: &[f64],
    ) -> Result<(), Box<dyn Error>> {
        if inputs.len() != values.len() {
            return Err("one start value per input".into());
        }
        let c = self.component;
        // SAFETY: a live instance; `inputs` and `values` have the length passed.
        unsafe {
            check(
                (self.fmi.setup)(c, 0, 0.0, 0.0, 1, stop),
                "fmi2SetupExperiment",
            )?;
            check(
                (self.fmi.set_real)(c, inputs.as_ptr(), inputs.len(), values.as_ptr()),
                "fmi2SetReal",
            )?;
            check((self.fmi.enter)(c), "fmi2EnterInitializationMode")?;
            check((self.fmi.exit)(c), "fmi2ExitInitializationMode")
        }
    }

    /// fmi2GetReal of the variables `vrs`.
    fn get(&self, vrs: &[c_uint]) -> Result<Vec<f64>, Box<dyn Error>> {
        let mut values = vec![0.0; vrs.len()];
        // SAFETY: a live instance; `values` holds one slot per reference.
        let status = unsafe {
            (self.fmi.get_real)(self.component, vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        };
        check(status, "fmi2GetReal")?;
        Ok(values)
    }

    /// fmi2DoStep from `t` over `h` [s].
    fn step(&self, t: f64, h: f64) -> Result<(), Box<dyn Error>> {
        // SAFETY: a live, initialised instance.
        check(
            unsafe { (self.fmi.do_step)(self.component, t, h, 1) },
            "fmi2DoStep",
        )
    }

    /// fmi2Terminate.
    fn terminate(&self) -> Result<(), Box<dyn Error>> {
        // SAFETY: a live instance.
        check(
            unsafe { (self.fmi.terminate)(self.component) },
            "fmi2Terminate",
        )
    }
}

impl Drop for Instance<'_> {
    fn drop(&mut self) {
        // SAFETY: the instance is live and not used after this.
        unsafe { (self.fmi.free)(self.component) }
    }
}

impl Sample {
    /// The sample at `time` of the values of [`OUTPUTS`], in that order.
    fn of(time: f64, y: &[f64]) -> Sample {
        Sample {
            time,
            x: y[0],
            v: y[1],
            p: y[2],
            q1: y[3],
            q2: y[4],
            e_x: y[5],
        }
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
    let (dir, library) = unpack(fmu)?;
    let result = run_unpacked(&dir, &library, [v_ref, load], duration, step);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// [`run_paper_case`] on the FMU unpacked into `dir`, whose shared library is `library`;
/// `inputs` are v_ref [m/s] and F_L [N].
fn run_unpacked(
    dir: &Path,
    library: &Path,
    inputs: [f64; 2],
    duration: f64,
    step: f64,
) -> Result<Vec<Sample>, Box<dyn Error>> {
    let xml = std::fs::read_to_string(dir.join("modelDescription.xml"))?;
    let guid = CString::new(attribute(&xml, "guid")?)?;
    let input_refs = [
        value_reference(&xml, "v_ref")?,
        value_reference(&xml, "F_L")?,
    ];
    let outputs: Vec<c_uint> = OUTPUTS
        .iter()
        .map(|n| value_reference(&xml, n))
        .collect::<Result<_, _>>()?;
    let resources = CString::new(format!("file://{}/resources", dir.display()))?;
    // SAFETY: the library is the FMU's FMI 2.0 Co-Simulation binary.
    let lib = unsafe { Library::new(library)? };
    // SAFETY: as above: its functions have the standard's signatures.
    let fmi = unsafe { Fmi2::load(&lib)? };
    let instance = Instance::new(&fmi, &guid, &resources)?;
    let n = (duration / step).round() as usize;
    instance.initialize(n as f64 * step, &input_refs, &inputs)?;
    // Communication points on the grid k * step (as FMPy does), not accumulated sums.
    let mut samples = vec![Sample::of(0.0, &instance.get(&outputs)?)];
    for k in 0..n {
        let (t, next) = (k as f64 * step, (k + 1) as f64 * step);
        instance.step(t, next - t)?;
        samples.push(Sample::of(next, &instance.get(&outputs)?));
    }
    instance.terminate()?;
    Ok(samples)
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
