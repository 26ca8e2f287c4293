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

/// How the binary was built: `cargo zigbuild x86_64-unknown-linux-gnu.2.17 (...)`, a
/// `native cargo build (...)` with the reason, or `cargo build` on other platforms
/// (`TBM_FMU_LINUX_BUILD`, see the build script).
pub const LINUX_BUILD: &str = env!("TBM_THRUST_FMU_LINUX_BUILD");

/// The oldest glibc the Linux binary was linked for ("2.17"), or "" when it was built
/// natively (it then needs the build machine's glibc) or is not a Linux binary.
pub const GLIBC: &str = env!("TBM_THRUST_FMU_GLIBC");
