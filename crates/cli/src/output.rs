//! Where the command writes: every output is checked before the work starts (writable, not
//! one of the inputs, not another output), files are written to a temporary name in their
//! folder and renamed, so a failure never leaves half a file, and standard output closed
//! early (`| head -1`) ends the command quietly.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The absolute, symlink-free form of a path that may not exist yet: its folder resolved,
/// its file name kept.
fn resolved(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let dir = match path.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(d) => d.to_path_buf(),
        None => PathBuf::from("."),
    };
    let dir = dir.canonicalize().unwrap_or(dir);
    match path.file_name() {
        Some(name) => dir.join(name),
        None => dir,
    }
}

/// Checks the outputs (option, path) against the inputs (option, path) and each other, and
/// that each output's folder exists or can be made and takes a file. `dirs` are output
/// folders (`--report DIR`): they must not be an existing file.
pub fn check(
    inputs: &[(&str, &Path)],
    files: &[(&str, &Path)],
    dirs: &[(&str, &Path)],
) -> Result<(), String> {
    for (i, (what, out)) in files.iter().enumerate() {
        let r = resolved(out);
        for (input, path) in inputs {
            if resolved(path) == r {
                return Err(format!(
                    "{what} {} is the {input} file: it would be overwritten; choose another name",
                    out.display()
                ));
            }
        }
        for (other, path) in &files[..i] {
            if resolved(path) == r {
                return Err(format!(
                    "{what} {} is also the {other} file; choose another name",
                    out.display()
                ));
            }
        }
        if r.is_dir() {
            return Err(format!("{what} {}: is a folder, not a file", out.display()));
        }
        if out.metadata().is_ok_and(|m| !m.is_file()) {
            continue; // a device or a pipe, written directly (`write_atomic_with`)
        }
        let dir = match out.parent().filter(|d| !d.as_os_str().is_empty()) {
            Some(d) => d.to_path_buf(),
            None => PathBuf::from("."),
        };
        writable_dir(what, &dir)?;
    }
    for (what, dir) in dirs {
        if dir.exists() && !dir.is_dir() {
            return Err(format!(
                "{what} {}: an existing file, not a folder",
                dir.display()
            ));
        }
        for (input, path) in inputs {
            if resolved(path).starts_with(resolved(dir)) && dir.join("report.md") == **path {
                return Err(format!(
                    "{what} {} would overwrite the {input} file",
                    dir.display()
                ));
            }
        }
        writable_dir(what, dir)?;
    }
    Ok(())
}

/// Creates `dir` if needed and proves that a file can be made in it.
fn writable_dir(what: &str, dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("{what}: cannot create the folder {}: {e}", dir.display()))?;
    let probe = dir.join(format!(".tbm-thrust-probe-{}", std::process::id()));
    std::fs::File::create(&probe)
        .map_err(|e| format!("{what}: cannot write in {}: {e}", dir.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Writes `text` to `path` through a temporary file in the same folder, renamed at the end.
pub fn write_atomic(path: &Path, text: &str) -> Result<(), String> {
    write_atomic_with(path, |w| w.write_all(text.as_bytes()))
}

/// Writes `path` with `write` through a temporary file in the same folder (buffered),
/// renamed at the end. A path that exists and is no regular file (`/dev/null`, a pipe) is
/// written directly: renaming onto it would replace it.
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), String> {
    let fail = |e: std::io::Error| format!("cannot write {}: {e}", path.display());
    if path.metadata().is_ok_and(|m| !m.is_file()) {
        let mut w = BufWriter::new(File::create(path).map_err(fail)?);
        return write(&mut w).and_then(|()| w.flush()).map_err(fail);
    }
    let dir = match path.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(d) => d.to_path_buf(),
        None => PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = removed_if_interrupted(&tmp, || {
        File::create(&tmp)
            .and_then(|f| {
                let mut w = BufWriter::new(f);
                write(&mut w)?;
                w.flush()
            })
            .and_then(|()| std::fs::rename(&tmp, path))
    })
    .map_err(fail);
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// The temporary file being written, for the signal handler: a C string leaked for the
/// duration of the write, or null.
#[cfg(unix)]
static WRITING: std::sync::atomic::AtomicPtr<libc::c_char> =
    std::sync::atomic::AtomicPtr::new(std::ptr::null_mut());

/// Ctrl-C, `kill` or a closed terminal while a file is written (a long `simulate` streams
/// for minutes): removes the temporary file, then ends the command as the signal would.
#[cfg(unix)]
extern "C" fn interrupted(signal: libc::c_int) {
    let path = WRITING.load(std::sync::atomic::Ordering::SeqCst);
    // SAFETY: unlink, signal and raise are async-signal-safe; `path` is null or a C string
    // that stays alive while it is published in WRITING.
    unsafe {
        if !path.is_null() {
            libc::unlink(path);
        }
        libc::signal(signal, libc::SIG_DFL);
        libc::raise(signal);
    }
}

/// Runs `write`, removing `tmp` if a signal ends the command meanwhile.
fn removed_if_interrupted<T>(tmp: &Path, write: impl FnOnce() -> T) -> T {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        use std::sync::atomic::Ordering::SeqCst;
        let Ok(c_path) = std::ffi::CString::new(tmp.as_os_str().as_bytes()) else {
            return write();
        };
        let raw = c_path.into_raw();
        WRITING.store(raw, SeqCst);
        for signal in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            // SAFETY: `interrupted` is an async-signal-safe handler (see there).
            unsafe { libc::signal(signal, interrupted as *const () as libc::sighandler_t) };
        }
        let result = write();
        WRITING.store(std::ptr::null_mut(), SeqCst);
        // SAFETY: `raw` came from `CString::into_raw` above and is no longer published.
        drop(unsafe { std::ffi::CString::from_raw(raw) });
        result
    }
    #[cfg(not(unix))]
    {
        let _ = tmp;
        write()
    }
}

/// Prints to standard output; a reader that has gone (`| head -1`) ends the command
/// quietly with success, as `cat` and `grep` do.
pub fn emit(text: &str) {
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error: cannot write to standard output: {e}");
        std::process::exit(1);
    }
}
