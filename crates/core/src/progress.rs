//! How integrators report progress without knowing about terminals (design.md: only the CLI and the
//! experiment runner touch indicatif).

/// Receives units of finished work (e.g. pixels of a pass, photons). Called from worker threads.
pub trait Progress: Sync {
    /// Announces how many units the whole job has.
    fn start(&self, total: u64);
    /// `n` more units are done.
    fn advance(&self, n: u64);
}

/// Ignores progress (tests, nested renders).
pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _total: u64) {}
    fn advance(&self, _n: u64) {}
}
