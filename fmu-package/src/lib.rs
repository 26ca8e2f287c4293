//! Where the build script of this crate put the FMU it packaged.
//!
//! The build script (`build.rs`) runs a nested `cargo build --release --lib -p tbm-thrust`
//! in its own target directory and zips the cdylib, the generated modelDescription.xml and
//! the documentation into `target/fmu/TbmThrust.fmu`. Tests, benchmarks and examples depend
//! on this crate so that the FMU is built before they run.

/// Absolute path of the packaged FMU (`<target dir>/fmu/TbmThrust.fmu`).
pub const FMU_PATH: &str = env!("TBM_THRUST_FMU_PATH");

/// FMI 2.0 platform folder of the packaged binary (`linux64`, `win64`, `darwin64`, ...).
pub const PLATFORM: &str = env!("TBM_THRUST_FMU_PLATFORM");

/// File name of the binary inside `binaries/<PLATFORM>/` (`tbm_thrust.so`, `.dll`, `.dylib`).
pub const LIBRARY_FILE: &str = env!("TBM_THRUST_FMU_LIBRARY");
