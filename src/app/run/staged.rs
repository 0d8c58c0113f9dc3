//! Whole-run output sets: a run writes everything it produces into staging
//! areas beside its targets and puts them in place at the end, so an output
//! directory holds one run's complete set (the previous one, or the new
//! one), never a mix of two, and a run that fails leaves nothing.
//!
//! * [`StagedOutputs::dir`] checks an output directory before any work: not
//!   a file, not a mount point, not the current directory or one holding it
//!   (a shell there would be left in a deleted directory), no input inside
//!   it, and if it exists and is
//!   not empty, a previous unfold output (its hidden manifest
//!   [`MANIFEST`] lists every file in it; anything else is somebody's file
//!   and the run is refused, never deleted). It removes the leftovers of
//!   killed runs beside it ([`clean_stale`]) and creates the staging
//!   directory `PARENT/.NAME.unfold-<pid>-<rand>.partial/`, where the
//!   command writes (nested runs in its subdirectories).
//! * [`StagedOutputs::file`] does the same for an output file outside the
//!   directories (a staging directory holding just that file, so the file
//!   keeps its name and extension); one inside a staged directory is
//!   written into its staging area.
//! * [`StagedOutputs::commit`] checks the targets again, writes each
//!   directory's manifest and puts everything in place: a directory by
//!   `rename` when its target is absent or empty, else by swapping the two
//!   (Linux `renameat2(RENAME_EXCHANGE)`; elsewhere, or where the file
//!   system lacks it, target -> `.NAME.unfold-<pid>-<rand>.old` then
//!   staging -> target, so the target is briefly absent but never mixed),
//!   then removes the previous set's listed files; a file by `rename`.
//!   Dropping without commit removes the staging areas and the parent
//!   directories it created.
//!
//! Between the renames of two targets (a directory and `--displacement`,
//! or `deform`'s mesh and report) a kill leaves the first target new and
//! the second old; each target on its own is always whole.

use super::OutputError;
use super::manifest::{MANIFEST, Manifest, parse_manifest};
use super::stale::{clean_stale, remove_listed};
use crate::io::{FilePath, IoError};
use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// How many foreign entries an error names.
const EXAMPLES: usize = 3;

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: FilePath(path.to_path_buf()),
        source,
    }
}

/// `p` absolute, with its deepest existing ancestor canonicalized
/// (symbolic links resolved) and the missing rest appended; lexical where
/// that fails.
fn resolve(p: &Path) -> PathBuf {
    let Ok(abs) = std::path::absolute(p) else {
        return p.to_path_buf();
    };
    let mut existing = abs.as_path();
    let mut rest = Vec::new();
    while std::fs::symlink_metadata(existing).is_err() {
        match (existing.file_name(), existing.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name);
                existing = parent;
            }
            _ => return abs,
        }
    }
    let Ok(mut out) = std::fs::canonicalize(existing) else {
        return abs;
    };
    out.extend(rest.iter().rev());
    out
}

/// The parent directory and the last name of an absolute path.
fn split(abs: &Path, shown: &Path) -> Result<(PathBuf, String), OutputError> {
    match (abs.parent(), abs.file_name()) {
        (Some(parent), Some(name)) => Ok((parent.to_path_buf(), name.to_string_lossy().into())),
        _ => Err(OutputError::NoName {
            path: FilePath(shown.to_path_buf()),
        }),
    }
}

/// Creates the directory `PARENT/.NAME.unfold-<pid>-<rand>.SUFFIX` (mode
/// `0777` less the umask, as any new directory).
fn make_dir_beside(parent: &Path, name: &str, suffix: &str) -> Result<PathBuf, OutputError> {
    let prefix = format!(".{name}.unfold-{}-", std::process::id());
    let mut b = tempfile::Builder::new();
    b.prefix(&prefix).suffix(suffix).rand_bytes(6);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        b.permissions(std::fs::Permissions::from_mode(0o777));
    }
    let dir = b.tempdir_in(parent).map_err(io_err(parent))?;
    Ok(dir.keep())
}

/// Flushes a directory's entries to disk (best effort; not on Windows).
fn sync_dir(dir: &Path) {
    #[cfg(unix)]
    if let Ok(f) = std::fs::File::open(dir) {
        let _ = f.sync_all();
    }
    #[cfg(not(unix))]
    let _ = dir;
}

/// Every non-directory below `dir`, relative and `/`-separated, sorted.
fn list_files(dir: &Path) -> Result<Vec<String>, OutputError> {
    fn walk(dir: &Path, rel: &str, out: &mut Vec<String>) -> Result<(), OutputError> {
        for entry in std::fs::read_dir(dir).map_err(io_err(dir))? {
            let entry = entry.map_err(io_err(dir))?;
            let name = entry.file_name().to_string_lossy().into_owned();
            let r = if rel.is_empty() {
                name
            } else {
                format!("{rel}/{name}")
            };
            let ft = entry.file_type().map_err(io_err(&entry.path()))?;
            if ft.is_dir() {
                walk(&entry.path(), &r, out)?;
            } else {
                out.push(r);
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, "", &mut out)?;
    out.sort();
    Ok(out)
}

/// Checks that the existing directory `dir` holds nothing but a previous
/// unfold output set: every file listed in its manifest, every directory
/// on the way to one. `shown` names it in errors.
fn check_set(dir: &Path, shown: &Path) -> Result<(), OutputError> {
    let (has_manifest, listed) = match std::fs::read(dir.join(MANIFEST)) {
        Ok(bytes) => (
            true,
            parse_manifest(&bytes).map_err(|reason| OutputError::BadManifest {
                path: FilePath(shown.to_path_buf()),
                reason,
            })?,
        ),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => (false, Vec::new()),
        Err(e) => return Err(io_err(&dir.join(MANIFEST))(e)),
    };
    let files: HashSet<&str> = listed.iter().map(String::as_str).collect();
    let dirs: HashSet<&str> = listed
        .iter()
        .flat_map(|f| f.match_indices('/').map(move |(i, _)| &f[..i]))
        .collect();
    let mut foreign = Vec::new();
    let mut stack = vec![(dir.to_path_buf(), String::new())];
    while let Some((d, rel)) = stack.pop() {
        let mut entries: Vec<_> = std::fs::read_dir(&d)
            .map_err(io_err(&d))?
            .collect::<Result<_, _>>()
            .map_err(io_err(&d))?;
        entries.sort_by_key(|e| e.file_name());
        for entry in entries {
            let name = entry.file_name().to_string_lossy().into_owned();
            let r = if rel.is_empty() {
                name
            } else {
                format!("{rel}/{name}")
            };
            let is_dir = entry.file_type().map_err(io_err(&entry.path()))?.is_dir();
            if r == MANIFEST && has_manifest && !is_dir {
                continue;
            }
            if is_dir && dirs.contains(r.as_str()) {
                stack.push((entry.path(), r));
            } else if !is_dir && files.contains(r.as_str()) {
                continue;
            } else {
                foreign.push(if is_dir { format!("{r}/") } else { r });
            }
        }
    }
    if foreign.is_empty() {
        return Ok(());
    }
    let mut examples = foreign[..foreign.len().min(EXAMPLES)].join(", ");
    if foreign.len() > EXAMPLES {
        examples.push_str(", ...");
    }
    Err(OutputError::ForeignFiles {
        path: FilePath(shown.to_path_buf()),
        count: foreign.len(),
        examples,
    })
}

/// Whether `dir` is a mount point (its device differs from its parent's).
fn is_mount_point(dir: &Path, parent: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(dir), std::fs::metadata(parent)) {
            (Ok(d), Ok(p)) => d.dev() != p.dev(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = (dir, parent);
        false
    }
}

/// Exchanges two directories atomically (Linux `renameat2` with
/// `RENAME_EXCHANGE`). `Ok(false)`: the system or file system cannot.
#[cfg(any(target_os = "linux", target_os = "android"))]
fn exchange(a: &Path, b: &Path) -> std::io::Result<bool> {
    use rustix::fs::{CWD, RenameFlags, renameat_with};
    use rustix::io::Errno;
    match renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE) {
        Ok(()) => Ok(true),
        Err(Errno::INVAL | Errno::NOSYS | Errno::OPNOTSUPP) => Ok(false),
        Err(e) => Err(e.into()),
    }
}

#[cfg(not(any(target_os = "linux", target_os = "android")))]
fn exchange(_: &Path, _: &Path) -> std::io::Result<bool> {
    Ok(false)
}

/// Removes a previous output set moved out of the way: only the files its
/// manifest lists (checked before the swap), and the directories left
/// empty. Without a readable manifest nothing is removed.
fn remove_previous(dir: &Path) {
    if let Some(files) = std::fs::read(dir.join(MANIFEST))
        .ok()
        .and_then(|b| parse_manifest(&b).ok())
    {
        remove_listed(dir, &files);
    }
}

/// Whether an output is a directory (a whole set) or one file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Dir,
    File,
}

/// One target being staged.
#[derive(Debug)]
struct Entry {
    kind: Kind,
    /// The target as the user gave it (for messages and reports).
    shown: PathBuf,
    /// The target, absolute (see [`resolve`]).
    target: PathBuf,
    /// The staging directory beside it: the set itself for a directory,
    /// the holder of the file (same name) for a file.
    staging: PathBuf,
    /// The file's name (for [`Kind::File`]).
    name: String,
    /// Put in place (nothing left to remove).
    done: bool,
}

/// The outputs of one run, staged beside their targets until
/// [`commit`](StagedOutputs::commit) (see the module documentation).
#[derive(Debug)]
pub struct StagedOutputs {
    inputs: Vec<(PathBuf, PathBuf)>,
    entries: Vec<Entry>,
    created: Vec<PathBuf>,
}

impl StagedOutputs {
    /// Starts a run that reads `inputs`: no output may be one of them or
    /// (for an output directory, replaced whole) hold one.
    pub fn new<P: AsRef<Path>>(inputs: impl IntoIterator<Item = P>) -> Self {
        let inputs = inputs
            .into_iter()
            .map(|p| (p.as_ref().to_path_buf(), resolve(p.as_ref())))
            .collect();
        StagedOutputs {
            inputs,
            entries: Vec::new(),
            created: Vec::new(),
        }
    }

    /// Checks the output directory `target` and returns the staging
    /// directory to write the set into (created; missing parents of
    /// `target` are created too). Refused: an existing file, a mount point,
    /// the current directory or one holding it,
    /// an input inside it, a non-empty directory that is not a previous
    /// unfold output (files not in its manifest). Removes dead runs'
    /// leftovers beside it.
    pub fn dir(&mut self, target: impl AsRef<Path>) -> Result<PathBuf, OutputError> {
        let shown = target.as_ref();
        if let Ok(m) = std::fs::metadata(shown)
            && !m.is_dir()
        {
            return Err(OutputError::NotADirectory {
                path: FilePath(shown.to_path_buf()),
            });
        }
        let abs = resolve(shown);
        let (parent, name) = split(&abs, shown)?;
        if let Some((input, _)) = self.inputs.iter().find(|(_, r)| r.starts_with(&abs)) {
            return Err(OutputError::InputIsOutput {
                input: FilePath(input.clone()),
                output: FilePath(shown.to_path_buf()),
            });
        }
        if let Ok(cwd) = std::env::current_dir().and_then(std::fs::canonicalize)
            && cwd.starts_with(&abs)
        {
            return Err(OutputError::CurrentDirectory {
                path: FilePath(shown.to_path_buf()),
            });
        }
        if abs.is_dir() {
            if is_mount_point(&abs, &parent) {
                return Err(OutputError::MountPoint {
                    path: FilePath(shown.to_path_buf()),
                });
            }
            check_set(&abs, shown)?;
        }
        self.create_parents(&parent)?;
        clean_stale(&parent);
        let staging = make_dir_beside(&parent, &name, ".partial")?;
        self.entries.push(Entry {
            kind: Kind::Dir,
            shown: shown.to_path_buf(),
            target: abs,
            staging: staging.clone(),
            name,
            done: false,
        });
        Ok(staging)
    }

    /// Checks the output file `target` and returns the path to write it at:
    /// inside a staged directory's area when `target` lies in one, else in
    /// a staging directory of its own beside it (same file name). Refused:
    /// an existing directory, a missing parent directory, an input. Removes
    /// dead runs' leftovers beside it.
    pub fn file(&mut self, target: impl AsRef<Path>) -> Result<PathBuf, OutputError> {
        let shown = target.as_ref();
        if std::fs::metadata(shown).is_ok_and(|m| m.is_dir()) {
            return Err(OutputError::IsADirectory {
                path: FilePath(shown.to_path_buf()),
            });
        }
        let abs = resolve(shown);
        if let Some((input, _)) = self.inputs.iter().find(|(_, r)| *r == abs) {
            return Err(OutputError::InputIsOutput {
                input: FilePath(input.clone()),
                output: FilePath(shown.to_path_buf()),
            });
        }
        let (parent, name) = split(&abs, shown)?;
        if let Some(e) = self
            .entries
            .iter()
            .find(|e| e.kind == Kind::Dir && abs.starts_with(&e.target) && abs != e.target)
        {
            let rel = abs.strip_prefix(&e.target).unwrap_or(&abs);
            let p = e.staging.join(rel);
            if let Some(d) = p.parent() {
                std::fs::create_dir_all(d).map_err(io_err(d))?;
            }
            return Ok(p);
        }
        if !parent.is_dir() {
            let dir = match shown.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            };
            return Err(OutputError::MissingDirectory {
                path: FilePath(shown.to_path_buf()),
                dir: FilePath(dir),
            });
        }
        clean_stale(&parent);
        let staging = make_dir_beside(&parent, &name, ".partial")?;
        let path = staging.join(&name);
        self.entries.push(Entry {
            kind: Kind::File,
            shown: shown.to_path_buf(),
            target: abs,
            staging,
            name,
            done: false,
        });
        Ok(path)
    }

    /// Where a path written into a staging area will be after the commit,
    /// as the user named the target (for messages and reports); any other
    /// path unchanged.
    pub fn shown(&self, path: &Path) -> PathBuf {
        for e in &self.entries {
            if let Ok(rel) = path.strip_prefix(&e.staging) {
                return match e.kind {
                    Kind::File => e.shown.clone(),
                    Kind::Dir if rel.as_os_str().is_empty() => e.shown.clone(),
                    Kind::Dir => e.shown.join(rel),
                };
            }
        }
        path.to_path_buf()
    }

    /// `text` (a message) with every staging path replaced by the path it
    /// will have after the commit. Staging names are unique
    /// (`.NAME.unfold-<pid>-<rand>.partial`), so nothing else is touched.
    pub fn shown_text(&self, text: &str) -> String {
        let mut out = text.to_string();
        for e in &self.entries {
            let (from, to) = match e.kind {
                Kind::File => (e.staging.join(&e.name), e.shown.clone()),
                Kind::Dir => (e.staging.clone(), e.shown.clone()),
            };
            out = out.replace(&from.display().to_string(), &to.display().to_string());
        }
        out
    }

    /// An error about a staged path, naming the path it will have after
    /// the commit instead.
    pub fn shown_error(&self, e: IoError) -> IoError {
        e.map_path(|p| self.shown(p))
    }

    /// Puts every staged output in place, in the order they were staged
    /// (see the module documentation). The output directories are checked
    /// again first (a file added to one meanwhile refuses the commit, and
    /// nothing moves). On an error the targets not yet replaced keep their
    /// previous contents. [`shown`](StagedOutputs::shown) still maps
    /// afterwards; a second commit does nothing.
    pub fn commit(&mut self) -> Result<(), OutputError> {
        for e in self.entries.iter().filter(|e| !e.done) {
            if e.kind == Kind::Dir && e.target.is_dir() {
                check_set(&e.target, &e.shown)?;
            }
        }
        for i in 0..self.entries.len() {
            let e = &self.entries[i];
            if e.done {
                continue;
            }
            match e.kind {
                Kind::Dir => put_dir(e, true)?,
                Kind::File => put_file(e)?,
            }
            self.entries[i].done = true;
        }
        // The parents made are now the targets' parents.
        self.created.clear();
        Ok(())
    }

    /// Creates `dir` and its missing ancestors, remembering which.
    fn create_parents(&mut self, dir: &Path) -> Result<(), OutputError> {
        let mut missing = Vec::new();
        let mut p = Some(dir);
        while let Some(d) = p {
            if d.as_os_str().is_empty() || std::fs::symlink_metadata(d).is_ok() {
                break;
            }
            missing.push(d.to_path_buf());
            p = d.parent();
        }
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        self.created.extend(missing.into_iter().rev());
        Ok(())
    }
}

impl Drop for StagedOutputs {
    /// A run that did not commit leaves nothing: its staging areas and the
    /// parent directories it created (when empty) are removed.
    fn drop(&mut self) {
        for e in self.entries.iter().filter(|e| !e.done) {
            let _ = std::fs::remove_dir_all(&e.staging);
        }
        for d in self.created.iter().rev() {
            let _ = std::fs::remove_dir(d);
        }
    }
}

/// Writes the manifest of a staged directory and puts it in place (an
/// occupied target swapped by `renameat2` when `try_exchange` and the
/// system can, else by two renames).
fn put_dir(e: &Entry, try_exchange: bool) -> Result<(), OutputError> {
    let files = list_files(&e.staging)?
        .into_iter()
        .filter(|f| f != MANIFEST)
        .collect();
    let manifest = Manifest {
        written_by: format!("unfold {}", env!("CARGO_PKG_VERSION")),
        files,
    };
    let json = serde_json::to_string_pretty(&manifest).map_err(|e| OutputError::Io {
        path: FilePath(PathBuf::from(MANIFEST)),
        source: std::io::Error::other(e),
    })?;
    let mpath = e.staging.join(MANIFEST);
    {
        use std::io::Write;
        let mut f = std::fs::File::create(&mpath).map_err(io_err(&mpath))?;
        f.write_all(format!("{json}\n").as_bytes())
            .map_err(io_err(&mpath))?;
        f.sync_all().map_err(io_err(&mpath))?;
    }
    sync_dir(&e.staging);
    let parent = e.target.parent().unwrap_or(Path::new("/"));
    let occupied = std::fs::read_dir(&e.target)
        .map(|mut it| it.next().is_some())
        .unwrap_or(false);
    if let Ok(m) = std::fs::metadata(&e.target) {
        // The directory keeps its permissions.
        let _ = std::fs::set_permissions(&e.staging, m.permissions());
    }
    if !occupied {
        // Absent, or an empty directory (which rename replaces).
        std::fs::rename(&e.staging, &e.target).map_err(io_err(&e.shown))?;
    } else if try_exchange && exchange(&e.staging, &e.target).map_err(io_err(&e.shown))? {
        // The staging name now holds the previous set.
        remove_previous(&e.staging);
    } else {
        let old = make_dir_beside(parent, &e.name, ".old")?;
        // `old` is empty, so the rename replaces it.
        std::fs::rename(&e.target, &old).map_err(io_err(&e.shown))?;
        if let Err(err) = std::fs::rename(&e.staging, &e.target) {
            let _ = std::fs::rename(&old, &e.target);
            return Err(io_err(&e.shown)(err));
        }
        remove_previous(&old);
    }
    sync_dir(parent);
    Ok(())
}

/// Puts a staged file in place (keeping the permissions of a file it
/// replaces) and removes its staging directory.
fn put_file(e: &Entry) -> Result<(), OutputError> {
    let staged = e.staging.join(&e.name);
    if let Ok(m) = std::fs::metadata(&e.target) {
        let _ = std::fs::set_permissions(&staged, m.permissions());
    }
    std::fs::rename(&staged, &e.target).map_err(io_err(&e.shown))?;
    let _ = std::fs::remove_dir(&e.staging);
    if let Some(parent) = e.target.parent() {
        sync_dir(parent);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The names in `dir` (not below it), sorted.
    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// Writes `files` (relative path, contents) below `dir`.
    fn write_all(dir: &Path, files: &[(&str, &str)]) {
        for (f, text) in files {
            let p = dir.join(f);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
    }

    /// One staged run writing `files` into `target`, committed.
    fn run(target: &Path, files: &[(&str, &str)]) {
        let mut s = StagedOutputs::new(Vec::<PathBuf>::new());
        let dir = s.dir(target).unwrap();
        write_all(&dir, files);
        s.commit().unwrap();
    }

    #[test]
    fn a_set_appears_whole_at_the_commit_with_its_manifest() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("a/b/out");
        let mut s = StagedOutputs::new(Vec::<PathBuf>::new());
        let dir = s.dir(&out).unwrap();
        assert_eq!(
            dir.parent().unwrap(),
            std::fs::canonicalize(tmp.path().join("a/b")).unwrap()
        );
        assert!(!out.exists(), "nothing at the target before the commit");
        write_all(&dir, &[("report.json", "{}"), ("figures/x.png", "png")]);
        assert_eq!(
            s.shown(&dir.join("figures/x.png")),
            out.join("figures/x.png")
        );
        assert_eq!(
            s.shown(Path::new("/else/where")),
            PathBuf::from("/else/where")
        );
        s.commit().unwrap();
        assert_eq!(names(&out), [MANIFEST, "figures", "report.json"]);
        assert_eq!(names(&tmp.path().join("a/b")), ["out"]);
        let m: Manifest =
            serde_json::from_slice(&std::fs::read(out.join(MANIFEST)).unwrap()).unwrap();
        assert_eq!(m.files, ["figures/x.png", "report.json"]);
        assert!(m.written_by.starts_with("unfold "));
    }

    #[test]
    fn a_run_that_does_not_commit_leaves_nothing() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("new/deeper/out");
        {
            let mut s = StagedOutputs::new(Vec::<PathBuf>::new());
            let dir = s.dir(&out).unwrap();
            write_all(&dir, &[("flattened.vtu", "mesh")]);
        }
        assert_eq!(names(tmp.path()), Vec::<String>::new());
        // With a previous set: it is untouched.
        run(&out, &[("report.json", "one")]);
        {
            let mut s = StagedOutputs::new(Vec::<PathBuf>::new());
            let dir = s.dir(&out).unwrap();
            write_all(&dir, &[("report.json", "two")]);
        }
        assert_eq!(
            std::fs::read_to_string(out.join("report.json")).unwrap(),
            "one"
        );
        assert_eq!(names(&tmp.path().join("new/deeper")), ["out"]);
    }

    #[test]
    fn a_second_run_replaces_the_whole_set_both_ways_of_swapping() {
        for try_exchange in [true, false] {
            let tmp = tempfile::tempdir().unwrap();
            let out = tmp.path().join("out");
            run(
                &out,
                &[("a.vtu", "1"), ("figures/f.png", "1"), ("report.json", "1")],
            );
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o750)).unwrap();
            }
            let mut s = StagedOutputs::new(Vec::<PathBuf>::new());
            let dir = s.dir(&out).unwrap();
            write_all(&dir, &[("a.vtu", "2"), ("report.json", "2")]);
            // Through `put_dir` directly, to cover the two-rename swap too.
            put_dir(&s.entries[0], try_exchange).unwrap();
            s.entries[0].done = true;
            drop(s);
            assert_eq!(
                names(&out),
                [MANIFEST, "a.vtu", "report.json"],
                "{try_exchange}"
            );
            assert_eq!(std::fs::read_to_string(out.join("a.vtu")).unwrap(), "2");
            assert_eq!(names(tmp.path()), ["out"], "{try_exchange}");
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                let mode = std::fs::metadata(&out).unwrap().permissions().mode();
                assert_eq!(mode & 0o777, 0o750, "the directory keeps its permissions");
            }
        }
    }

    #[test]
    fn foreign_files_refuse_the_directory_and_stay() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        write_all(&out, &[("mine.txt", "keep")]);
        let mut s = StagedOutputs::new(Vec::<PathBuf>::new());
        let e = s.dir(&out).unwrap_err();
        assert!(
            matches!(e, OutputError::ForeignFiles { count: 1, .. }),
            "{e}"
        );
        let msg = e.to_string();
        assert!(
            msg.contains("mine.txt") && msg.contains("choose a new or empty directory"),
            "{msg}"
        );
        assert_eq!(names(tmp.path()), ["out"], "nothing created");
        // Beside a previous set: only the unlisted ones are named.
        let out2 = tmp.path().join("out2");
        run(&out2, &[("report.json", "1"), ("figures/f.png", "1")]);
        write_all(
            &out2,
            &[("figures/g.png", "x"), ("z/1", "x"), ("y", "x"), ("x", "x")],
        );
        let e = s.dir(&out2).unwrap_err();
        match &e {
            OutputError::ForeignFiles {
                count, examples, ..
            } => {
                assert_eq!(*count, 4);
                assert_eq!(examples, "x, y, z/, ...");
            }
            e => panic!("{e}"),
        }
        assert_eq!(std::fs::read_to_string(out2.join("y")).unwrap(), "x");
        // A manifest not ours.
        let out3 = tmp.path().join("out3");
        write_all(&out3, &[(MANIFEST, "{\"files\": 3}")]);
        let e = s.dir(&out3).unwrap_err();
        assert!(matches!(e, OutputError::BadManifest { .. }), "{e}");
        // A file somebody adds during the run refuses the commit.
        let out4 = tmp.path().join("out4");
        run(&out4, &[("report.json", "1")]);
        let mut s = StagedOutputs::new(Vec::<PathBuf>::new());
        let dir = s.dir(&out4).unwrap();
        write_all(&dir, &[("report.json", "2")]);
        write_all(&out4, &[("notes.txt", "mine")]);
        let e = s.commit().unwrap_err();
        assert!(
            matches!(e, OutputError::ForeignFiles { count: 1, .. }),
            "{e}"
        );
        assert_eq!(names(&out4), [MANIFEST, "notes.txt", "report.json"]);
        assert_eq!(
            std::fs::read_to_string(out4.join("report.json")).unwrap(),
            "1"
        );
        // The failed run, dropped, leaves nothing.
        drop(s);
        assert_eq!(names(tmp.path()), ["out", "out2", "out3", "out4"]);
    }

    #[test]
    fn paths_that_cannot_be_outputs_are_refused_before_anything_is_made() {
        let tmp = tempfile::tempdir().unwrap();
        let input = tmp.path().join("in/mesh.vtu");
        write_all(tmp.path(), &[("in/mesh.vtu", "m"), ("file", "f")]);
        let mut s = StagedOutputs::new([&input]);
        let e = s.dir(tmp.path().join("file")).unwrap_err();
        assert!(matches!(e, OutputError::NotADirectory { .. }), "{e}");
        assert!(e.to_string().contains("-o needs a directory"), "{e}");
        let e = s.dir(tmp.path().join("in")).unwrap_err();
        assert!(matches!(e, OutputError::InputIsOutput { .. }), "{e}");
        assert!(
            e.to_string()
                .starts_with(&format!("{}: is an input", input.display())),
            "{e}"
        );
        let e = s.file(&input).unwrap_err();
        assert!(matches!(e, OutputError::InputIsOutput { .. }), "{e}");
        let e = s.file(tmp.path().join("in")).unwrap_err();
        assert!(matches!(e, OutputError::IsADirectory { .. }), "{e}");
        let e = s.file(tmp.path().join("missing/x.vtu")).unwrap_err();
        assert!(matches!(e, OutputError::MissingDirectory { .. }), "{e}");
        assert!(e.to_string().contains("missing"), "{e}");
        let e = s.dir("/").unwrap_err();
        assert!(matches!(e, OutputError::NoName { .. }), "{e}");
        // The current directory (the package root, under `cargo test`).
        let e = s.dir(".").unwrap_err();
        assert!(matches!(e, OutputError::CurrentDirectory { .. }), "{e}");
        assert!(e.to_string().contains("-o out"), "{e}");
        assert_eq!(names(tmp.path()), ["file", "in"]);
        assert_eq!(names(&tmp.path().join("in")), ["mesh.vtu"]);
    }

    #[test]
    fn files_alone_or_inside_a_staged_directory() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        let lone = tmp.path().join("disp.nii.gz");
        std::fs::write(&lone, "old").unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&lone, std::fs::Permissions::from_mode(0o640)).unwrap();
        }
        let mut s = StagedOutputs::new(Vec::<PathBuf>::new());
        let dir = s.dir(&out).unwrap();
        let inner = s.file(out.join("sub/d.nii.gz")).unwrap();
        assert_eq!(inner, dir.join("sub/d.nii.gz"));
        let staged = s.file(&lone).unwrap();
        assert_eq!(staged.file_name().unwrap(), "disp.nii.gz");
        assert_ne!(
            staged.parent().unwrap(),
            std::fs::canonicalize(tmp.path()).unwrap()
        );
        assert_eq!(s.shown(&staged), lone);
        let msg = format!("{}: disk full; see {}", staged.display(), inner.display());
        assert_eq!(
            s.shown_text(&msg),
            format!(
                "{}: disk full; see {}",
                lone.display(),
                out.join("sub/d.nii.gz").display()
            )
        );
        let e = s.shown_error(crate::io::IoError::unsupported("no").with_path(&staged));
        assert_eq!(e.to_string(), format!("{}: no", lone.display()));
        assert_eq!(s.shown(&inner), out.join("sub/d.nii.gz"));
        std::fs::write(&inner, "inner").unwrap();
        std::fs::write(&staged, "new").unwrap();
        assert_eq!(std::fs::read_to_string(&lone).unwrap(), "old");
        s.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&lone).unwrap(), "new");
        assert_eq!(
            std::fs::read_to_string(out.join("sub/d.nii.gz")).unwrap(),
            "inner"
        );
        assert_eq!(names(tmp.path()), ["disp.nii.gz", "out"]);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&lone).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o640, "a replaced file keeps its permissions");
        }
    }

    #[test]
    fn a_dead_runs_staging_beside_the_target_is_removed() {
        let tmp = tempfile::tempdir().unwrap();
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let stale = tmp.path().join(format!(".out.unfold-{dead}-k1.partial"));
        write_all(&stale, &[("flattened.vtu", "half")]);
        run(&tmp.path().join("out"), &[("report.json", "1")]);
        assert_eq!(names(tmp.path()), ["out"]);
    }

    #[test]
    fn exchange_swaps_two_directories_or_leaves_both() {
        let tmp = tempfile::tempdir().unwrap();
        let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
        write_all(&a, &[("1", "a")]);
        write_all(&b, &[("2", "b")]);
        let swapped = exchange(&a, &b).unwrap();
        if cfg!(target_os = "linux") {
            // tmpfs, ext4, xfs, btrfs all have it.
            assert!(swapped, "renameat2(RENAME_EXCHANGE) unsupported here");
        }
        let (one, two) = if swapped { (&b, &a) } else { (&a, &b) };
        assert_eq!(names(one), ["1"]);
        assert_eq!(names(two), ["2"]);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// Whatever two runs write, the directory holds exactly the second
        /// run's files (and its manifest), and nothing is left beside it.
        #[test]
        fn the_target_holds_exactly_the_last_committed_set(
            first in proptest::collection::btree_set("[a-c]{1,2}(/[a-c]{1,2})?\\.f", 0..6),
            second in proptest::collection::btree_set("[a-c]{1,2}(/[a-c]{1,2})?\\.f", 0..6),
        ) {
            let tmp = tempfile::tempdir().unwrap();
            let out = tmp.path().join("out");
            for set in [&first, &second] {
                let files: Vec<(&str, &str)> = set.iter().map(|f| (f.as_str(), "x")).collect();
                run(&out, &files);
            }
            let mut want: Vec<String> = second.iter().cloned().collect();
            want.push(MANIFEST.to_string());
            want.sort();
            let got = list_files(&out).unwrap();
            prop_assert_eq!(got, want);
            prop_assert_eq!(names(tmp.path()), ["out"]);
            prop_assert!(check_set(&out, &out).is_ok());
        }
    }
}
