//! A small FMI 2.0 importer for the tests and the benchmark: it unzips the packaged FMU
//! (target/fmu/TbmThrust.fmu), loads its library with libloading, looks up every FMI 2.0
//! Co-Simulation function and records what the FMU logs.
//!
//! The logger: Rust cannot define a C-variadic function on stable, so [`capture`] is an
//! ordinary `extern "C"` function with the one string argument this FMU always passes
//! after `"%s"`, cast to the variadic pointer type. On x86_64 and aarch64 Linux and on
//! Windows x64 a variadic call passes that argument exactly like a sixth fixed one.

use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};
use tbm_thrust::fmi::types::*;

macro_rules! api {
    ($($field:ident = $sym:literal : fn($($arg:ty),*) $(-> $ret:ty)?;)*) => {
        /// Every function of the FMI 2.0 Co-Simulation API, as loaded from the library.
        pub struct Api { $(pub $field: unsafe extern "C" fn($($arg),*) $(-> $ret)?,)* }
        /// The names of all of them.
        pub const SYMBOLS: &[&str] = &[$($sym),*];
        impl Api {
            unsafe fn load(lib: &libloading::Library) -> Result<Self, libloading::Error> {
                Ok(Api { $($field: *lib.get(concat!($sym, "\0").as_bytes())?,)* })
            }
        }
    };
}

type C = Fmi2Component;
type Vr = *const Fmi2ValueReference;
type S = Fmi2Status;

api! {
    get_types_platform = "fmi2GetTypesPlatform": fn() -> *const c_char;
    get_version = "fmi2GetVersion": fn() -> *const c_char;
    set_debug_logging = "fmi2SetDebugLogging": fn(C, Fmi2Boolean, usize, *const Fmi2String) -> S;
    instantiate = "fmi2Instantiate": fn(Fmi2String, c_int, Fmi2String, Fmi2String, *const Fmi2CallbackFunctions, Fmi2Boolean, Fmi2Boolean) -> C;
    free_instance = "fmi2FreeInstance": fn(C);
    setup_experiment = "fmi2SetupExperiment": fn(C, Fmi2Boolean, f64, f64, Fmi2Boolean, f64) -> S;
    enter_initialization_mode = "fmi2EnterInitializationMode": fn(C) -> S;
    exit_initialization_mode = "fmi2ExitInitializationMode": fn(C) -> S;
    terminate = "fmi2Terminate": fn(C) -> S;
    reset = "fmi2Reset": fn(C) -> S;
    get_real = "fmi2GetReal": fn(C, Vr, usize, *mut f64) -> S;
    get_integer = "fmi2GetInteger": fn(C, Vr, usize, *mut Fmi2Integer) -> S;
    get_boolean = "fmi2GetBoolean": fn(C, Vr, usize, *mut Fmi2Boolean) -> S;
    get_string = "fmi2GetString": fn(C, Vr, usize, *mut Fmi2String) -> S;
    set_real = "fmi2SetReal": fn(C, Vr, usize, *const f64) -> S;
    set_integer = "fmi2SetInteger": fn(C, Vr, usize, *const Fmi2Integer) -> S;
    set_boolean = "fmi2SetBoolean": fn(C, Vr, usize, *const Fmi2Boolean) -> S;
    set_string = "fmi2SetString": fn(C, Vr, usize, *const Fmi2String) -> S;
    get_fmu_state = "fmi2GetFMUstate": fn(C, *mut Fmi2FmuState) -> S;
    set_fmu_state = "fmi2SetFMUstate": fn(C, Fmi2FmuState) -> S;
    free_fmu_state = "fmi2FreeFMUstate": fn(C, *mut Fmi2FmuState) -> S;
    serialized_fmu_state_size = "fmi2SerializedFMUstateSize": fn(C, Fmi2FmuState, *mut usize) -> S;
    serialize_fmu_state = "fmi2SerializeFMUstate": fn(C, Fmi2FmuState, *mut Fmi2Byte, usize) -> S;
    deserialize_fmu_state = "fmi2DeSerializeFMUstate": fn(C, *const Fmi2Byte, usize, *mut Fmi2FmuState) -> S;
    get_directional_derivative = "fmi2GetDirectionalDerivative": fn(C, Vr, usize, Vr, usize, *const f64, *mut f64) -> S;
    set_real_input_derivatives = "fmi2SetRealInputDerivatives": fn(C, Vr, usize, *const Fmi2Integer, *const f64) -> S;
    get_real_output_derivatives = "fmi2GetRealOutputDerivatives": fn(C, Vr, usize, *const Fmi2Integer, *mut f64) -> S;
    do_step = "fmi2DoStep": fn(C, f64, f64, Fmi2Boolean) -> S;
    cancel_step = "fmi2CancelStep": fn(C) -> S;
    get_status = "fmi2GetStatus": fn(C, c_int, *mut c_int) -> S;
    get_real_status = "fmi2GetRealStatus": fn(C, c_int, *mut f64) -> S;
    get_integer_status = "fmi2GetIntegerStatus": fn(C, c_int, *mut Fmi2Integer) -> S;
    get_boolean_status = "fmi2GetBooleanStatus": fn(C, c_int, *mut Fmi2Boolean) -> S;
    get_string_status = "fmi2GetStringStatus": fn(C, c_int, *mut Fmi2String) -> S;
}

/// The unpacked FMU with its library loaded.
pub struct Fmu {
    pub api: Api,
    pub dir: PathBuf,
    pub model_description: String,
    _library: libloading::Library,
}

/// The packaged FMU, unpacked once per test process.
pub fn packaged() -> &'static Fmu {
    static FMU: OnceLock<Fmu> = OnceLock::new();
    FMU.get_or_init(|| Fmu::load(Path::new(tbm_thrust_fmu::FMU_PATH)))
}

impl Fmu {
    pub fn load(fmu: &Path) -> Fmu {
        let dir = std::env::temp_dir().join(format!("tbm-thrust-fmi-test-{}", std::process::id()));
        unzip(fmu, &dir);
        let library_path = dir
            .join("binaries")
            .join(tbm_thrust_fmu::PLATFORM)
            .join(tbm_thrust_fmu::LIBRARY_FILE);
        // SAFETY: our own FMU library; its initialisers have no side effects.
        let library =
            unsafe { libloading::Library::new(&library_path) }.expect("load the FMU's library");
        let api =
            unsafe { Api::load(&library) }.expect("the library exports every FMI 2.0 CS function");
        let model_description = std::fs::read_to_string(dir.join("modelDescription.xml")).unwrap();
        // The loaded library stays mapped; do not leave a copy per test run in the temp dir.
        let _ = std::fs::remove_dir_all(&dir);
        Fmu {
            api,
            dir,
            model_description,
            _library: library,
        }
    }

    /// The `guid` attribute of the packaged modelDescription.xml.
    pub fn guid(&self) -> &str {
        let start = self
            .model_description
            .find("guid=\"")
            .expect("guid attribute")
            + 6;
        let len = self.model_description[start..].find('"').unwrap();
        &self.model_description[start..start + len]
    }

    /// A Co-Simulation instance with the packaged GUID, logging everything.
    pub fn instance(&self, name: &str) -> Instance<'_> {
        let guid = self.guid().to_string();
        self.instantiate(name, FMI2_CO_SIMULATION, &guid, true)
            .expect("fmi2Instantiate")
    }

    /// fmi2Instantiate with a capturing logger; Err(messages) if it returned NULL.
    pub fn instantiate(
        &self,
        name: &str,
        fmu_type: c_int,
        guid: &str,
        logging_on: bool,
    ) -> Result<Instance<'_>, Vec<LogEntry>> {
        let log = Box::new(Log::default());
        let callbacks = Box::new(Fmi2CallbackFunctions {
            logger: Some(variadic_logger()),
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: &*log as *const Log as *mut c_void,
        });
        let (name, guid) = (CString::new(name).unwrap(), CString::new(guid).unwrap());
        let resources =
            CString::new(format!("file://{}/resources%20dir", self.dir.display())).unwrap();
        let c = unsafe {
            (self.api.instantiate)(
                name.as_ptr(),
                fmu_type,
                guid.as_ptr(),
                resources.as_ptr(),
                &*callbacks,
                0,
                logging_on as c_int,
            )
        };
        if c.is_null() {
            return Err(log.take());
        }
        Ok(Instance {
            fmu: self,
            c,
            log,
            _callbacks: callbacks,
        })
    }
}

fn unzip(fmu: &Path, dir: &Path) {
    let file = std::fs::File::open(fmu)
        .unwrap_or_else(|e| panic!("{}: {e} (run `cargo build --release`)", fmu.display()));
    let mut archive = zip::ZipArchive::new(file).expect("the FMU is a zip file");
    archive.extract(dir).expect("unpack the FMU");
}

/// One logger call.
#[derive(Clone, Debug)]
pub struct LogEntry {
    pub instance: String,
    pub status: c_int,
    pub category: String,
    pub format: String,
    pub message: String,
}

/// The messages of one instance (the logger's componentEnvironment).
#[derive(Default)]
pub struct Log(Mutex<Vec<LogEntry>>);

impl Log {
    pub fn take(&self) -> Vec<LogEntry> {
        std::mem::take(&mut *self.0.lock().unwrap())
    }
}

unsafe extern "C" fn capture(
    env: *mut c_void,
    instance: Fmi2String,
    status: c_int,
    category: Fmi2String,
    format: Fmi2String,
    text: Fmi2String,
) {
    let s = |p: Fmi2String| {
        if p.is_null() {
            "<NULL>".to_string()
        } else {
            CStr::from_ptr(p).to_string_lossy().into_owned()
        }
    };
    let entry = LogEntry {
        instance: s(instance),
        status,
        category: s(category),
        format: s(format),
        message: s(text),
    };
    (*(env as *const Log)).0.lock().unwrap().push(entry);
}

type VariadicLogger =
    unsafe extern "C" fn(*mut c_void, Fmi2String, c_int, Fmi2String, Fmi2String, ...);

fn variadic_logger() -> VariadicLogger {
    // SAFETY: see the module comment; the FMU always calls it with exactly one argument after the format.
    unsafe {
        std::mem::transmute::<unsafe extern "C" fn(_, _, _, _, _, _), VariadicLogger>(capture)
    }
}

/// One instance with its log; freed on drop.
pub struct Instance<'a> {
    pub fmu: &'a Fmu,
    pub c: Fmi2Component,
    pub log: Box<Log>,
    _callbacks: Box<Fmi2CallbackFunctions>,
}

// SAFETY: an instance may be used from any thread, one at a time (FMI 2.0); the log is a Mutex.
unsafe impl Send for Instance<'_> {}

impl Instance<'_> {
    pub fn api(&self) -> &Api {
        &self.fmu.api
    }

    /// SetupExperiment(start, stop), EnterInitializationMode, ExitInitializationMode.
    pub fn initialize(&self, start: f64, stop: Option<f64>) {
        let a = self.api();
        unsafe {
            assert_eq!(
                (a.setup_experiment)(
                    self.c,
                    0,
                    0.0,
                    start,
                    stop.is_some() as c_int,
                    stop.unwrap_or(0.0)
                ),
                S::Ok
            );
            assert_eq!((a.enter_initialization_mode)(self.c), S::Ok);
            assert_eq!((a.exit_initialization_mode)(self.c), S::Ok);
        }
    }

    pub fn set_real(&self, vrs: &[u32], values: &[f64]) -> S {
        assert_eq!(vrs.len(), values.len());
        unsafe { (self.api().set_real)(self.c, vrs.as_ptr(), vrs.len(), values.as_ptr()) }
    }

    pub fn set_integer(&self, vrs: &[u32], values: &[i32]) -> S {
        unsafe { (self.api().set_integer)(self.c, vrs.as_ptr(), vrs.len(), values.as_ptr()) }
    }

    pub fn get_reals(&self, vrs: &[u32]) -> Result<Vec<f64>, S> {
        let mut values = vec![f64::NAN; vrs.len()];
        match unsafe { (self.api().get_real)(self.c, vrs.as_ptr(), vrs.len(), values.as_mut_ptr()) }
        {
            S::Ok => Ok(values),
            status => Err(status),
        }
    }

    pub fn get_real(&self, vr: u32) -> f64 {
        self.get_reals(&[vr]).expect("fmi2GetReal")[0]
    }

    pub fn do_step(&self, t: f64, h: f64) -> S {
        unsafe { (self.api().do_step)(self.c, t, h, 1) }
    }

    /// The messages logged since the last call (each checked to use the "%s" format).
    pub fn messages(&self) -> Vec<LogEntry> {
        let messages = self.log.take();
        for m in &messages {
            assert_eq!(m.format, "%s", "the logger's format must be \"%s\": {m:?}");
        }
        messages
    }

    /// The error messages logged since the last call, joined by newlines.
    pub fn errors(&self) -> String {
        let errors: Vec<String> = self
            .messages()
            .into_iter()
            .filter(|e| e.status >= S::Error as c_int)
            .map(|e| e.message)
            .collect();
        errors.join("\n")
    }
}

impl Drop for Instance<'_> {
    fn drop(&mut self) {
        unsafe { (self.api().free_instance)(self.c) }
    }
}
