//! How long work reports itself. The library never draws or prints: it tells a [`Progress`] what
//! it is doing, and the `dualhair` binary draws bars and prints the notes. [`Silent`] tells nobody.

/// The receiver of a long job's reports.
pub trait Progress: Sync {
    /// Work called `what` of `len` steps begins (`None`: of unknown length); the returned [`Task`]
    /// is advanced as steps finish, and the work ends when it is dropped.
    fn task(&self, what: &str, len: Option<u64>) -> Box<dyn Task + '_>;

    /// A line worth telling the user: what was built and how long it took, what is waited for.
    fn note(&self, line: &str);
}

/// One running piece of work ([`Progress::task`]).
pub trait Task: Sync {
    /// `steps` more steps are done.
    fn advance(&self, steps: u64);

    /// Where the work is now (e.g. "8 of 32 spp").
    fn status(&self, status: &str);
}

/// Reports to nobody: for tests, benchmarks and quiet runs.
pub struct Silent;

impl Progress for Silent {
    fn task(&self, _: &str, _: Option<u64>) -> Box<dyn Task + '_> {
        Box::new(Silent)
    }

    fn note(&self, _: &str) {}
}

impl Task for Silent {
    fn advance(&self, _: u64) {}

    fn status(&self, _: &str) {}
}
