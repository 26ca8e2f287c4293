//! How far a long computation has got, told to whoever shows it: the command draws a bar,
//! the library draws nothing.

/// Told the work a computation finds (in units of roughly equal cost, e.g. one fit) and the
/// work it finishes; called from worker threads.
pub trait Progress: Sync {
    /// `units` more work was found.
    fn found(&self, units: u64);
    /// `units` of the work found is done.
    fn done(&self, units: u64);
}

/// Progress told to no one.
pub struct Silent;

impl Progress for Silent {
    fn found(&self, _: u64) {}
    fn done(&self, _: u64) {}
}
