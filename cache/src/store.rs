use std::collections::{BTreeMap, HashMap, HashSet};
use std::fs::{self, File};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use serde::{Deserialize, Serialize};

use crate::digest::Digest;

#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    #[error("cache {path}: {source}")]
    Io { path: PathBuf, source: io::Error },
    #[error("cache entry {digest} is corrupt ({what}); discarded")]
    Corrupt { digest: String, what: String },
    #[error("cache object {0} is missing")]
    Missing(String),
    #[error("cache {0} is in use by a running study; try again when it ends")]
    Busy(PathBuf),
    #[error(
        "cache {path} is shared by the members of group {group}, and you are not one: ask its \
         owner to add you to the group, or give a cache of your own (--cache DIR)"
    )]
    NotAMember { path: PathBuf, group: String },
}

/// The error of a write to a read-only mount or a folder the user may not write.
fn is_read_only(err: &io::Error) -> bool {
    matches!(
        err.kind(),
        io::ErrorKind::ReadOnlyFilesystem | io::ErrorKind::PermissionDenied
    )
}

fn io_error(path: &Path) -> impl FnOnce(io::Error) -> CacheError + '_ {
    move |source| CacheError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// What a cache key resolved to: the digest of each output, by output name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ActionRecord {
    /// The stage instance that produced it, for reports.
    pub stage: String,
    pub kind: String,
    pub outputs: BTreeMap<String, Digest>,
    /// Seconds the stage took when it ran.
    pub wall_s: f64,
}

#[derive(Debug, Default, Clone, PartialEq)]
pub struct Stats {
    pub actions: usize,
    pub objects: usize,
    pub object_bytes: u64,
    pub stray_temporaries: usize,
}

#[derive(Debug, Default, Clone)]
pub struct VerifyReport {
    pub actions_checked: usize,
    pub objects_checked: usize,
    /// One line per corrupt or dangling entry found (and discarded).
    pub problems: Vec<String>,
}

/// What `gc` keeps.
#[derive(Debug, Default, Clone)]
pub struct GcPolicy {
    /// Keep only these action records (and what they reference); `None` keeps all.
    pub keep_keys: Option<HashSet<Digest>>,
    /// Then drop least-recently-used records (never those in `keep_keys`) until the objects
    /// they reference fit in this many bytes.
    pub max_bytes: Option<u64>,
}

#[derive(Debug, Default, Clone)]
pub struct GcReport {
    pub actions_removed: usize,
    pub objects_removed: usize,
    pub bytes_freed: u64,
    pub bytes_kept: u64,
    /// What this user may not remove (another's files in a folder not shared with it), with
    /// the reason; the rest was collected.
    pub not_removed: Vec<String>,
}

/// Who may use a cache.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sharing {
    /// The user who writes it; others read what the umask lets them (the default).
    Private,
    /// Every member of the cache folder's group: folders group-writable and setgid (so that
    /// every entry stays in the group), entries read-only for the group, nothing for others.
    Group,
}

/// The file that makes a cache shared, written by [`Cache::init_shared`].
const CONFIG: &str = "config.json";

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Config {
    /// `group`: see [`Sharing::Group`].
    shared: String,
}

/// A shared cache's folders: owner and group may list, enter and add; setgid.
#[cfg(unix)]
const GROUP_FOLDER_MODE: u32 = 0o2770;
/// A shared cache's entries: read-only for owner and group.
#[cfg(unix)]
const GROUP_ENTRY_MODE: u32 = 0o440;

/// A handle on a cache directory. Holds the directory's lock (shared, or exclusive for `gc`)
/// for as long as it lives.
pub struct Cache {
    root: PathBuf,
    sharing: Sharing,
    _lock: File,
}

impl Cache {
    /// Opens (creating if needed) a cache shared with other runs.
    pub fn open(root: impl Into<PathBuf>) -> Result<Cache, CacheError> {
        let root = root.into();
        let sharing = read_sharing(&root)?;
        let lock = Self::lock_file(&root, sharing)?;
        lock.lock_shared().map_err(io_error(&root))?;
        Ok(Cache {
            root,
            sharing,
            _lock: lock,
        })
    }

    /// Opens the cache for maintenance (`gc`): fails with [`CacheError::Busy`] while any run
    /// holds it.
    pub fn open_exclusive(root: impl Into<PathBuf>) -> Result<Cache, CacheError> {
        let root = root.into();
        let sharing = read_sharing(&root)?;
        let lock = Self::lock_file(&root, sharing)?;
        match lock.try_lock() {
            Ok(()) => Ok(Cache {
                root,
                sharing,
                _lock: lock,
            }),
            Err(fs::TryLockError::WouldBlock) => Err(CacheError::Busy(root)),
            Err(fs::TryLockError::Error(source)) => Err(CacheError::Io { path: root, source }),
        }
    }

    /// Makes `root` (created if needed) a cache shared by the members of its group: the
    /// folders, every shard folder included, mode 2770 (so that a member never has to create
    /// one), the lock file 0660, the entries already there 0440. The group is the folder's:
    /// create it with the team's group first (`install -d -g TEAM DIR`, or `chgrp`).
    #[cfg(unix)]
    pub fn init_shared(root: impl Into<PathBuf>) -> Result<Cache, CacheError> {
        use std::os::unix::fs::PermissionsExt;
        let root = root.into();
        let folder = |path: &Path| -> Result<(), CacheError> {
            match fs::create_dir(path) {
                Err(err) if err.kind() != io::ErrorKind::AlreadyExists => {
                    return Err(CacheError::Io {
                        path: path.to_path_buf(),
                        source: err,
                    });
                }
                _ => {}
            }
            fs::set_permissions(path, fs::Permissions::from_mode(GROUP_FOLDER_MODE))
                .map_err(io_error(path))
        };
        fs::create_dir_all(&root).map_err(io_error(&root))?;
        folder(&root)?;
        for dir in ["objects", "actions", "tmp"] {
            folder(&root.join(dir))?;
        }
        for dir in ["objects", "actions"] {
            for shard in 0..=255u8 {
                folder(&root.join(dir).join(format!("{shard:02x}")))?;
            }
            for entry in list_entries(&root.join(dir))? {
                let path = root.join(dir).join(entry.shard_path());
                fs::set_permissions(&path, fs::Permissions::from_mode(GROUP_ENTRY_MODE))
                    .map_err(io_error(&path))?;
            }
        }
        let lock = root.join("LOCK");
        File::options()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock)
            .map_err(io_error(&lock))?;
        fs::set_permissions(&lock, fs::Permissions::from_mode(0o660)).map_err(io_error(&lock))?;
        let config = root.join(CONFIG);
        let text = serde_json::to_vec(&Config {
            shared: "group".into(),
        })
        .expect("the configuration serialises");
        let _ = fs::remove_file(&config);
        fs::write(&config, text).map_err(io_error(&config))?;
        fs::set_permissions(&config, fs::Permissions::from_mode(GROUP_ENTRY_MODE))
            .map_err(io_error(&config))?;
        Cache::open(root)
    }

    fn lock_file(root: &Path, sharing: Sharing) -> Result<File, CacheError> {
        if sharing == Sharing::Group {
            check_membership(root)?;
        }
        for dir in ["objects", "actions", "tmp"] {
            let path = root.join(dir);
            match fs::create_dir_all(&path) {
                Err(err) if !(path.is_dir() && is_read_only(&err)) => {
                    return Err(CacheError::Io { path, source: err });
                }
                _ => {}
            }
        }
        let path = root.join("LOCK");
        match File::options()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
        {
            Ok(file) => Ok(file),
            // A cache on a read-only mount still serves what it holds: lock it for reading
            // (a lock needs no write access); storing fails, each time with its reason.
            Err(err) if path.exists() && is_read_only(&err) => {
                File::open(&path).map_err(io_error(&path))
            }
            Err(source) => Err(CacheError::Io { path, source }),
        }
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    fn object_path(&self, digest: &Digest) -> PathBuf {
        let hex = digest.hex();
        self.root.join("objects").join(&hex[..2]).join(hex)
    }

    fn action_path(&self, key: &Digest) -> PathBuf {
        let hex = key.hex();
        self.root.join("actions").join(&hex[..2]).join(hex)
    }

    /// Writes `bytes` to `path` atomically: temporary file, fsync, rename, fsync of the folder.
    /// An entry is read-only: for everyone the umask lets read it in a private cache (0444
    /// under umask 022), for owner and group in a shared one.
    fn write_atomic(&self, path: &Path, bytes: &[u8]) -> Result<(), CacheError> {
        let tmp_dir = self.root.join("tmp");
        let mut builder = tempfile::Builder::new();
        let prefix = format!("{}-", std::process::id());
        builder.prefix(&prefix);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            // Created read-only (the umask then clears what it clears); the open file stays
            // writable.
            builder.permissions(fs::Permissions::from_mode(0o444));
        }
        let mut tmp = builder
            .tempfile_in(&tmp_dir)
            .map_err(|source| self.store_error(&tmp_dir, source))?;
        tmp.write_all(bytes).map_err(io_error(tmp.path()))?;
        #[cfg(unix)]
        if self.sharing == Sharing::Group {
            // Not left to the umask: the group must read what a member stores.
            use std::os::unix::fs::PermissionsExt;
            tmp.as_file()
                .set_permissions(fs::Permissions::from_mode(GROUP_ENTRY_MODE))
                .map_err(io_error(tmp.path()))?;
        }
        tmp.as_file().sync_all().map_err(io_error(tmp.path()))?;
        let dir = path.parent().expect("cache paths have a parent");
        self.create_folder(dir)?;
        tmp.persist(path)
            .map_err(|err| self.store_error(path, err.error))?;
        File::open(dir)
            .and_then(|dir| dir.sync_all())
            .map_err(io_error(dir))
    }

    /// Creates a shard folder: in a shared cache, group-writable and setgid, whatever the umask
    /// (`init_shared` made them all: this mends one removed since).
    fn create_folder(&self, dir: &Path) -> Result<(), CacheError> {
        if dir.is_dir() {
            return Ok(());
        }
        fs::create_dir_all(dir).map_err(|source| self.store_error(dir, source))?;
        #[cfg(unix)]
        if self.sharing == Sharing::Group {
            use std::os::unix::fs::PermissionsExt;
            fs::set_permissions(dir, fs::Permissions::from_mode(GROUP_FOLDER_MODE))
                .map_err(io_error(dir))?;
        }
        Ok(())
    }

    /// A failed write into the cache, said with what to do when it is a permission.
    fn store_error(&self, path: &Path, source: io::Error) -> CacheError {
        if source.kind() == io::ErrorKind::PermissionDenied && self.sharing == Sharing::Private {
            return CacheError::Io {
                path: path.to_path_buf(),
                source: io::Error::new(
                    source.kind(),
                    format!(
                        "{source}: a private cache takes entries from its owner only; share it \
                         with a group (`squeal cache init --shared group DIR`) or give a cache \
                         of your own (--cache DIR)"
                    ),
                ),
            };
        }
        CacheError::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    /// Stores bytes under their digest. Storing the same bytes twice is a no-op.
    pub fn put_object(&self, bytes: &[u8]) -> Result<Digest, CacheError> {
        let digest = Digest::of(bytes);
        let path = self.object_path(&digest);
        if !path.exists() {
            self.write_atomic(&path, bytes)?;
        }
        Ok(digest)
    }

    /// Reads an object and checks its digest; a corrupt object is deleted and reported.
    pub fn get_object(&self, digest: &Digest) -> Result<Vec<u8>, CacheError> {
        let path = self.object_path(digest);
        let bytes = match fs::read(&path) {
            Ok(bytes) => bytes,
            Err(err) if err.kind() == io::ErrorKind::NotFound => {
                return Err(CacheError::Missing(digest.hex()));
            }
            Err(source) => return Err(CacheError::Io { path, source }),
        };
        if Digest::of(&bytes) != *digest {
            let _ = fs::remove_file(&path);
            return Err(CacheError::Corrupt {
                digest: digest.hex(),
                what: "object bytes do not match their digest".into(),
            });
        }
        Ok(bytes)
    }

    /// Checks that an object is present and intact without keeping its bytes.
    pub fn verify_object(&self, digest: &Digest) -> Result<(), CacheError> {
        self.get_object(digest).map(drop)
    }

    /// Records what `key` produced. Written after its objects, so a visible record always
    /// points at complete objects.
    pub fn put_action(&self, key: &Digest, record: &ActionRecord) -> Result<(), CacheError> {
        let json = serde_json::to_vec(record).expect("action records serialise");
        let mut bytes = format!("{}\n", Digest::of(&json)).into_bytes();
        bytes.extend_from_slice(&json);
        self.write_atomic(&self.action_path(key), &bytes)
    }

    /// Looks `key` up. `Ok(None)`: never computed (or collected). A record whose checksum fails
    /// is deleted and reported as corrupt. A hit refreshes the record's time for LRU `gc`.
    pub fn get_action(&self, key: &Digest) -> Result<Option<ActionRecord>, CacheError> {
        let path = self.action_path(key);
        let bytes = match fs::read(&path) {
            Ok(bytes) => bytes,
            Err(err) if err.kind() == io::ErrorKind::NotFound => return Ok(None),
            Err(source) => return Err(CacheError::Io { path, source }),
        };
        match parse_action(&bytes) {
            Some(record) => {
                // The owner may set the time of a read-only file; in a shared cache, another
                // member's hit leaves it (gc's LRU order is the owner's).
                if let Ok(file) = File::open(&path) {
                    let _ = file.set_modified(SystemTime::now());
                }
                Ok(Some(record))
            }
            None => {
                let _ = fs::remove_file(&path);
                Err(CacheError::Corrupt {
                    digest: key.hex(),
                    what: "action record fails its checksum".into(),
                })
            }
        }
    }

    /// Forgets `key` (its objects stay until `gc`).
    pub fn remove_action(&self, key: &Digest) -> Result<(), CacheError> {
        let path = self.action_path(key);
        match fs::remove_file(&path) {
            // A read-only mount refuses even to remove what is not there.
            Err(err) if err.kind() != io::ErrorKind::NotFound && path.exists() => {
                Err(CacheError::Io { path, source: err })
            }
            _ => Ok(()),
        }
    }

    pub fn stats(&self) -> Result<Stats, CacheError> {
        let objects = list_entries(&self.root.join("objects"))?;
        Ok(Stats {
            actions: list_entries(&self.root.join("actions"))?.len(),
            objects: objects.len(),
            object_bytes: objects.iter().map(|entry| entry.bytes).sum(),
            stray_temporaries: list_files(&self.root.join("tmp"))?.len(),
        })
    }

    /// Re-hashes every object and checks every action record and what it references.
    /// Corrupt entries are discarded (they will be recomputed) and listed in the report.
    pub fn verify(&self) -> Result<VerifyReport, CacheError> {
        let mut report = VerifyReport::default();
        let mut intact = HashSet::new();
        for entry in list_entries(&self.root.join("objects"))? {
            report.objects_checked += 1;
            match self.get_object(&entry.digest) {
                Ok(_) => {
                    intact.insert(entry.digest);
                }
                Err(err) => report.problems.push(err.to_string()),
            }
        }
        for entry in list_entries(&self.root.join("actions"))? {
            report.actions_checked += 1;
            match self.get_action(&entry.digest) {
                Ok(Some(record)) => {
                    let dangling: Vec<&String> = record
                        .outputs
                        .iter()
                        .filter(|(_, digest)| !intact.contains(*digest))
                        .map(|(name, _)| name)
                        .collect();
                    if !dangling.is_empty() {
                        self.remove_action(&entry.digest)?;
                        report.problems.push(format!(
                            "cache entry {} of stage {} lost its output(s) {dangling:?}; discarded",
                            entry.digest, record.stage
                        ));
                    }
                }
                Ok(None) => {}
                Err(err) => report.problems.push(err.to_string()),
            }
        }
        Ok(report)
    }

    /// Removes stray temporaries, then action records and objects as `policy` says.
    /// Needs a cache opened with [`Cache::open_exclusive`].
    pub fn gc(&self, policy: &GcPolicy) -> Result<GcReport, CacheError> {
        let mut report = GcReport::default();
        // Another user's file may be beyond this one's reach: say so and go on.
        let remove = |path: &Path, report: &mut GcReport| -> Result<bool, CacheError> {
            match fs::remove_file(path) {
                Ok(()) => Ok(true),
                Err(err) if err.kind() == io::ErrorKind::NotFound => Ok(false),
                Err(err) if err.kind() == io::ErrorKind::PermissionDenied => {
                    report
                        .not_removed
                        .push(format!("{}: {err}", path.display()));
                    Ok(false)
                }
                Err(source) => Err(CacheError::Io {
                    path: path.to_path_buf(),
                    source,
                }),
            }
        };
        for path in list_files(&self.root.join("tmp"))? {
            remove(&path, &mut report)?;
        }
        let mut actions = Vec::new();
        for entry in list_entries(&self.root.join("actions"))? {
            let pinned = policy
                .keep_keys
                .as_ref()
                .map(|keep| keep.contains(&entry.digest));
            let record = match (pinned, self.get_action_untouched(&entry.digest)) {
                (Some(false), _) | (_, None) => {
                    if remove(&self.action_path(&entry.digest), &mut report)? {
                        report.actions_removed += 1;
                    }
                    continue;
                }
                (_, Some(record)) => record,
            };
            actions.push((entry, pinned == Some(true), record));
        }
        let objects: HashMap<Digest, u64> = list_entries(&self.root.join("objects"))?
            .into_iter()
            .map(|entry| (entry.digest, entry.bytes))
            .collect();
        let mut references: HashMap<Digest, usize> = HashMap::new();
        for (_, _, record) in &actions {
            for digest in record.outputs.values() {
                *references.entry(*digest).or_default() += 1;
            }
        }
        let mut bytes_kept: u64 = references
            .keys()
            .filter_map(|digest| objects.get(digest))
            .sum();
        if let Some(max_bytes) = policy.max_bytes {
            // Least recently used first; pinned records are never evicted.
            actions.sort_by_key(|(entry, _, _)| entry.modified);
            for (entry, pinned, record) in &actions {
                if bytes_kept <= max_bytes {
                    break;
                }
                if *pinned {
                    continue;
                }
                if !remove(&self.action_path(&entry.digest), &mut report)? {
                    continue;
                }
                report.actions_removed += 1;
                for digest in record.outputs.values() {
                    let count = references.get_mut(digest).expect("counted above");
                    *count -= 1;
                    if *count == 0 {
                        references.remove(digest);
                        bytes_kept -= objects.get(digest).copied().unwrap_or(0);
                    }
                }
            }
        }
        for (digest, bytes) in &objects {
            if !references.contains_key(digest) && remove(&self.object_path(digest), &mut report)? {
                report.objects_removed += 1;
                report.bytes_freed += bytes;
            }
        }
        report.bytes_kept = bytes_kept;
        Ok(report)
    }

    /// Reads a record without refreshing its LRU time (gc must not reorder what it sorts).
    fn get_action_untouched(&self, key: &Digest) -> Option<ActionRecord> {
        fs::read(self.action_path(key))
            .ok()
            .and_then(|bytes| parse_action(&bytes))
    }
}

/// How the cache at `root` is shared: its `config.json`, if any.
fn read_sharing(root: &Path) -> Result<Sharing, CacheError> {
    let path = root.join(CONFIG);
    let bytes = match fs::read(&path) {
        Ok(bytes) => bytes,
        Err(err) if err.kind() == io::ErrorKind::NotFound => return Ok(Sharing::Private),
        Err(err) if err.kind() == io::ErrorKind::PermissionDenied => {
            // A shared cache's configuration is the group's to read: say whose it is.
            check_membership(root)?;
            return Err(CacheError::Io { path, source: err });
        }
        Err(source) => return Err(CacheError::Io { path, source }),
    };
    let config: Config = serde_json::from_slice(&bytes).map_err(|err| CacheError::Io {
        path: path.clone(),
        source: io::Error::new(io::ErrorKind::InvalidData, err.to_string()),
    })?;
    match config.shared.as_str() {
        "group" => Ok(Sharing::Group),
        other => Err(CacheError::Io {
            path,
            source: io::Error::new(
                io::ErrorKind::InvalidData,
                format!("`shared: {other}`: the one sharing is `group`"),
            ),
        }),
    }
}

/// Refuses a user outside the group of a shared cache's folder (root is never refused).
#[cfg(unix)]
fn check_membership(root: &Path) -> Result<(), CacheError> {
    use std::os::unix::fs::MetadataExt;
    let gid = fs::metadata(root).map_err(io_error(root))?.gid();
    // SAFETY: getegid and geteuid cannot fail; getgroups writes at most `capacity` ids.
    let member = unsafe {
        let mut groups = vec![0 as libc::gid_t; 256];
        let count = libc::getgroups(groups.len() as libc::c_int, groups.as_mut_ptr());
        libc::geteuid() == 0
            || libc::getegid() == gid
            || (count > 0 && groups[..count as usize].contains(&gid))
    };
    if member {
        Ok(())
    } else {
        // SAFETY: getgrgid returns null or a record valid until the next call on this thread.
        let name = unsafe {
            let record = libc::getgrgid(gid);
            (!record.is_null()).then(|| {
                std::ffi::CStr::from_ptr((*record).gr_name)
                    .to_string_lossy()
                    .into_owned()
            })
        };
        Err(CacheError::NotAMember {
            path: root.to_path_buf(),
            group: name.map_or(format!("{gid}"), |name| format!("`{name}` ({gid})")),
        })
    }
}

#[cfg(not(unix))]
fn check_membership(_root: &Path) -> Result<(), CacheError> {
    Ok(())
}

fn parse_action(bytes: &[u8]) -> Option<ActionRecord> {
    let newline = bytes.iter().position(|&byte| byte == b'\n')?;
    let (checksum, json) = (&bytes[..newline], &bytes[newline + 1..]);
    let checksum: Digest = std::str::from_utf8(checksum).ok()?.parse().ok()?;
    if Digest::of(json) != checksum {
        return None;
    }
    serde_json::from_slice(json).ok()
}

struct Entry {
    digest: Digest,
    bytes: u64,
    modified: SystemTime,
}

impl Entry {
    /// `ab/abcdef…`, under `objects/` or `actions/`.
    #[cfg(unix)]
    fn shard_path(&self) -> PathBuf {
        let hex = self.digest.hex();
        Path::new(&hex[..2]).join(&hex)
    }
}

/// Every `ab/abcdef…` file under `dir`; files whose names are not digests are ignored.
fn list_entries(dir: &Path) -> Result<Vec<Entry>, CacheError> {
    let mut entries = Vec::new();
    for shard in list_files(dir)? {
        if !shard.is_dir() {
            continue;
        }
        for path in list_files(&shard)? {
            let Some(digest) = path
                .file_name()
                .and_then(|name| name.to_str()?.parse().ok())
            else {
                continue;
            };
            let metadata = fs::metadata(&path).map_err(io_error(&path))?;
            let modified = metadata.modified().unwrap_or(SystemTime::UNIX_EPOCH);
            entries.push(Entry {
                digest,
                bytes: metadata.len(),
                modified,
            });
        }
    }
    Ok(entries)
}

fn list_files(dir: &Path) -> Result<Vec<PathBuf>, CacheError> {
    match fs::read_dir(dir) {
        Ok(read_dir) => read_dir
            .map(|entry| entry.map(|entry| entry.path()).map_err(io_error(dir)))
            .collect(),
        Err(err) if err.kind() == io::ErrorKind::NotFound => Ok(Vec::new()),
        Err(source) => Err(CacheError::Io {
            path: dir.to_path_buf(),
            source,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Replaces a (read-only) entry's bytes, as a disk fault would.
    fn overwrite(path: &Path, bytes: &[u8]) {
        fs::remove_file(path).unwrap();
        fs::write(path, bytes).unwrap();
    }

    fn record(stage: &str, outputs: &[(&str, Digest)]) -> ActionRecord {
        ActionRecord {
            stage: stage.into(),
            kind: "test".into(),
            outputs: outputs
                .iter()
                .map(|(name, digest)| (name.to_string(), *digest))
                .collect(),
            wall_s: 0.0,
        }
    }

    #[test]
    fn objects_round_trip_and_corruption_is_detected() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        let digest = cache.put_object(b"stiffness").unwrap();
        assert_eq!(cache.get_object(&digest).unwrap(), b"stiffness");
        let path = cache.object_path(&digest);
        overwrite(&path, b"stiffnesS");
        assert!(matches!(
            cache.get_object(&digest),
            Err(CacheError::Corrupt { .. })
        ));
        assert!(!path.exists(), "a corrupt object is discarded");
        assert!(matches!(
            cache.get_object(&digest),
            Err(CacheError::Missing(_))
        ));
    }

    #[test]
    fn action_records_carry_a_checksum() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        let key = Digest::of(b"key");
        let digest = cache.put_object(b"mass").unwrap();
        let expected = record("assemble", &[("M", digest)]);
        cache.put_action(&key, &expected).unwrap();
        assert_eq!(cache.get_action(&key).unwrap(), Some(expected));
        let path = cache.action_path(&key);
        let mut bytes = fs::read(&path).unwrap();
        let last = bytes.len() - 2;
        bytes[last] ^= 1;
        overwrite(&path, &bytes);
        assert!(matches!(
            cache.get_action(&key),
            Err(CacheError::Corrupt { .. })
        ));
        assert_eq!(cache.get_action(&key).unwrap(), None);
    }

    #[test]
    fn gc_keeps_pinned_keys_and_evicts_least_recently_used() {
        let dir = tempfile::tempdir().unwrap();
        let key = |name: &str| Digest::of(name.as_bytes());
        {
            let cache = Cache::open(dir.path()).unwrap();
            for (idx, name) in ["old", "middle", "new"].iter().enumerate() {
                let digest = cache.put_object(&vec![idx as u8; 1000]).unwrap();
                cache
                    .put_action(&key(name), &record(name, &[("out", digest)]))
                    .unwrap();
                let path = cache.action_path(&key(name));
                let time =
                    SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1000 + idx as u64);
                File::options()
                    .write(true)
                    .open(path)
                    .unwrap()
                    .set_modified(time)
                    .unwrap();
            }
            fs::write(dir.path().join("tmp/123-stray"), b"half").unwrap();
            assert!(matches!(
                Cache::open_exclusive(dir.path()),
                Err(CacheError::Busy(_))
            ));
        }
        let cache = Cache::open_exclusive(dir.path()).unwrap();
        let policy = GcPolicy {
            keep_keys: None,
            max_bytes: Some(2000),
        };
        let report = cache.gc(&policy).unwrap();
        assert_eq!((report.actions_removed, report.objects_removed), (1, 1));
        assert_eq!(cache.get_action(&key("old")).unwrap(), None);
        assert!(cache.get_action(&key("middle")).unwrap().is_some());
        let stats = cache.stats().unwrap();
        assert_eq!(
            (stats.actions, stats.objects, stats.stray_temporaries),
            (2, 2, 0)
        );

        let keep = HashSet::from([key("middle")]);
        let policy = GcPolicy {
            keep_keys: Some(keep),
            max_bytes: Some(0),
        };
        cache.gc(&policy).unwrap();
        assert!(cache.get_action(&key("middle")).unwrap().is_some());
        assert_eq!(cache.stats().unwrap().objects, 1);
    }

    #[test]
    fn verify_discards_records_whose_objects_are_corrupt() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::open(dir.path()).unwrap();
        let digest = cache.put_object(b"modes").unwrap();
        let key = Digest::of(b"key");
        cache
            .put_action(&key, &record("modes", &[("modes", digest)]))
            .unwrap();
        assert!(cache.verify().unwrap().problems.is_empty());
        overwrite(&cache.object_path(&digest), b"modeS");
        let report = cache.verify().unwrap();
        assert_eq!(report.problems.len(), 2, "{:?}", report.problems);
        assert!(report.problems[1].contains("stage modes"));
        assert_eq!(cache.get_action(&key).unwrap(), None);
        assert!(cache.verify().unwrap().problems.is_empty());
    }
}
