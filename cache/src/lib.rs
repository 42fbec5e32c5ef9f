//! Content-addressed, verified, crash-safe store for stage results.
//!
//! Two levels, as in Bazel's remote cache:
//! - **objects**: artifact bytes, named by their blake3 digest (`objects/ab/abcdef…`);
//! - **actions**: a record per cache key (`actions/ab/…`) listing the digests of the outputs
//!   a stage produced for that key.
//!
//! Invariants:
//! - An entry is complete and verified, or absent. Every file is written to `tmp/`, fsynced and
//!   renamed into place; a killed writer leaves at most a stray temporary file, which `gc`
//!   removes. Objects are re-hashed on every read and action records carry a checksum: a
//!   mismatch is reported as [`CacheError::Corrupt`], the file is discarded, and the caller
//!   recomputes.
//! - Any number of processes may use one cache at once: they hold a shared lock on `LOCK`, and
//!   identical content written twice lands on the same name. Only `gc` takes the lock
//!   exclusively. The locks are the operating system's (`flock`), so a lock held by a killed
//!   process is released with it.
//! - Entries are read-only. A private cache leaves their mode to the umask (0444 under 022);
//!   a cache shared by a group ([`Sharing::Group`], `config.json` at its top, made by
//!   [`Cache::init_shared`]) has setgid, group-writable folders and entries 0440, so that every
//!   member reads and adds entries and nobody outside the group opens it.

mod digest;
mod store;

pub use digest::{Digest, ParseDigestError};
pub use store::{
    ActionRecord, Cache, CacheError, GcPolicy, GcReport, Sharing, Stats, VerifyReport,
};
