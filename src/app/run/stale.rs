//! Leftovers of killed runs: recognising them by name and removing them.
//!
//! A run that is killed (SIGKILL, power loss) leaves what it was writing:
//! `.unfold-<pid>-<rand>.tmp` files of [`atomic_write`](crate::io::atomic_write)
//! and `.NAME.unfold-<pid>-<rand>.partial` (or `.old`) directories of
//! [`StagedOutputs`](super::StagedOutputs). The next run writing in the
//! same directory removes those whose process is gone: on Linux when
//! `/proc/<pid>` does not exist, elsewhere (or without `/proc`) when the
//! entry is older than [`STALE_AGE`]. Only names of exactly these patterns
//! are ever touched (a user's `.unfold-notes.tmp` is not), temporary files
//! only when they are regular files and staging areas only when they are
//! directories (never through a symbolic link).

use super::manifest::{MANIFEST, parse_manifest};
use std::path::Path;
use std::time::Duration;

/// Where `/proc` is not available: a leftover older than this is stale.
pub const STALE_AGE: Duration = Duration::from_secs(24 * 3600);

/// What a name says it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Leftover {
    /// `.unfold-<pid>-<rand>.tmp`: a file being written by `atomic_write`.
    TempFile {
        /// The process that wrote it.
        pid: u32,
    },
    /// `.NAME.unfold-<pid>-<rand>.partial` or `.old`: a staging directory.
    StagingDir {
        /// The process that made it.
        pid: u32,
    },
}

/// `<pid>-<rand>`: a positive decimal pid, a dash, one or more ASCII
/// letters or digits.
fn pid_and_rand(s: &str) -> Option<u32> {
    let (pid, rand) = s.split_once('-')?;
    let valid = !pid.is_empty()
        && pid.bytes().all(|b| b.is_ascii_digit())
        && !rand.is_empty()
        && rand.bytes().all(|b| b.is_ascii_alphanumeric());
    if !valid {
        return None;
    }
    pid.parse().ok().filter(|&p| p > 0)
}

/// What the file name `name` is, if one of our patterns.
pub(crate) fn classify(name: &str) -> Option<Leftover> {
    if let Some(mid) = name
        .strip_prefix(".unfold-")
        .and_then(|s| s.strip_suffix(".tmp"))
    {
        return pid_and_rand(mid).map(|pid| Leftover::TempFile { pid });
    }
    let stem = name
        .strip_suffix(".partial")
        .or_else(|| name.strip_suffix(".old"))?;
    let at = stem.rfind(".unfold-")?;
    // `.NAME.unfold-...`: a dot, then a non-empty NAME.
    if at < 2 || !stem.starts_with('.') {
        return None;
    }
    pid_and_rand(&stem[at + ".unfold-".len()..]).map(|pid| Leftover::StagingDir { pid })
}

/// Whether process `pid` may still be running: ours always; on Linux with
/// `/proc` mounted, whether `/proc/<pid>` exists; otherwise whether the
/// entry (modified at `modified`) is younger than [`STALE_AGE`].
pub(crate) fn may_be_alive(pid: u32, modified: Option<std::time::SystemTime>) -> bool {
    if pid == std::process::id() {
        return true;
    }
    if cfg!(target_os = "linux") && Path::new("/proc/self").exists() {
        return Path::new(&format!("/proc/{pid}")).exists();
    }
    match modified.and_then(|m| m.elapsed().ok()) {
        Some(age) => age < STALE_AGE,
        // A time in the future, or none: keep it.
        None => true,
    }
}

/// Removes the leftovers of dead runs directly in `dir` (not below it) and
/// returns their paths. Best effort: an entry that cannot be removed is left
/// (the next run tries again) and a directory that cannot be read yields
/// nothing.
pub fn clean_stale(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut removed = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return removed;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(kind) = name.to_str().and_then(classify) else {
            continue;
        };
        // Not followed: a link named like ours is not ours.
        let Ok(meta) = std::fs::symlink_metadata(entry.path()) else {
            continue;
        };
        let (pid, ok_type) = match kind {
            Leftover::TempFile { pid } => (pid, meta.is_file()),
            Leftover::StagingDir { pid } => (pid, meta.is_dir()),
        };
        if !ok_type || may_be_alive(pid, meta.modified().ok()) {
            continue;
        }
        let path = entry.path();
        let gone = match kind {
            Leftover::TempFile { .. } => std::fs::remove_file(&path).is_ok(),
            Leftover::StagingDir { .. } => remove_staging(&path),
        };
        if gone {
            removed.push(path);
        }
    }
    removed
}

/// Removes a staging directory of ours: with a manifest (a committed set,
/// or the previous set swapped out) only the files it lists, the
/// directories they leave empty and the manifest; without one (a run killed
/// before its commit, where only unfold wrote) all of it. Returns whether
/// the directory is gone.
pub(crate) fn remove_staging(dir: &Path) -> bool {
    match std::fs::read(dir.join(MANIFEST)) {
        Ok(bytes) => match parse_manifest(&bytes) {
            Ok(files) => remove_listed(dir, &files),
            // An unreadable manifest: nothing is removed on its word.
            Err(_) => false,
        },
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => std::fs::remove_dir_all(dir).is_ok(),
        Err(_) => false,
    }
}

/// Removes the listed files of `dir`, then its directories that are left
/// empty (deepest first); the manifest and `dir` itself go last, only when
/// nothing else is left (so a file somebody added is never removed, and the
/// manifest stays to say what is ours). Returns whether `dir` is gone.
pub(crate) fn remove_listed(dir: &Path, files: &[String]) -> bool {
    for f in files {
        if f.split('/').any(|c| c.is_empty() || c == "." || c == "..") {
            continue;
        }
        let _ = std::fs::remove_file(dir.join(f));
    }
    let mut subdirs: Vec<std::path::PathBuf> = files
        .iter()
        .flat_map(|f| {
            let parts: Vec<&str> = f.split('/').collect();
            (1..parts.len())
                .map(move |n| parts[..n].join("/"))
                .collect::<Vec<_>>()
        })
        .filter(|d| !d.split('/').any(|c| c.is_empty() || c == "." || c == ".."))
        .map(|d| dir.join(d))
        .collect();
    // Deepest first.
    subdirs.sort_by_key(|d| std::cmp::Reverse(d.components().count()));
    subdirs.dedup();
    for d in subdirs {
        let _ = std::fs::remove_dir(d);
    }
    let only_manifest = std::fs::read_dir(dir)
        .map(|it| {
            it.flatten()
                .all(|e| e.file_name() == std::ffi::OsStr::new(MANIFEST))
        })
        .unwrap_or(false);
    if !only_manifest {
        return false;
    }
    let _ = std::fs::remove_file(dir.join(MANIFEST));
    std::fs::remove_dir(dir).is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_of_our_patterns_only() {
        assert_eq!(
            classify(".unfold-123-x.tmp"),
            Some(Leftover::TempFile { pid: 123 })
        );
        assert_eq!(
            classify(".unfold-9-aB3xYz.tmp"),
            Some(Leftover::TempFile { pid: 9 })
        );
        assert_eq!(
            classify(".out.unfold-77-Qw12.partial"),
            Some(Leftover::StagingDir { pid: 77 })
        );
        assert_eq!(
            classify(".a.unfold-b.unfold-5-z.old"),
            Some(Leftover::StagingDir { pid: 5 })
        );
        for not_ours in [
            ".unfold-notes.tmp",
            ".unfold-12.tmp",
            ".unfold--x.tmp",
            ".unfold-12-.tmp",
            ".unfold-0-x.tmp",
            ".unfold-1a-x.tmp",
            ".unfold-12-x-y.tmp",
            ".unfold-12-x.tmp.bak",
            "unfold-12-x.tmp",
            ".unfold-12-x.partial",
            "out.unfold-12-x.partial",
            "..unfold-12-x.partial",
            ".out.unfold-12.partial",
            ".out.unfold-12-x.y.partial",
            ".out.unfold-99999999999-x.partial",
            "report.json",
        ] {
            assert_eq!(classify(not_ours), None, "{not_ours}");
        }
    }

    /// A pid that is certainly not running: a child that has exited and
    /// been waited for.
    fn dead_pid() -> u32 {
        let mut child = std::process::Command::new("true")
            .spawn()
            .or_else(|_| {
                std::process::Command::new("cmd")
                    .args(["/C", "exit"])
                    .spawn()
            })
            .expect("a child process starts");
        let pid = child.id();
        child.wait().unwrap();
        pid
    }

    #[test]
    fn dead_runs_leftovers_are_removed_live_ones_and_users_files_kept() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let dead = dead_pid();
        let me = std::process::id();
        let old = std::time::SystemTime::now() - STALE_AGE - Duration::from_secs(60);
        let stale_tmp = d.join(format!(".unfold-{dead}-x.tmp"));
        let live_tmp = d.join(format!(".unfold-{me}-y.tmp"));
        let user = d.join(".unfold-notes.tmp");
        let stale_dir = d.join(format!(".out.unfold-{dead}-abc.partial"));
        let live_dir = d.join(format!(".out.unfold-{me}-abc.partial"));
        for f in [&stale_tmp, &live_tmp, &user] {
            std::fs::write(f, b"x").unwrap();
        }
        for s in [&stale_dir, &live_dir] {
            std::fs::create_dir_all(s.join("figures")).unwrap();
            std::fs::write(s.join("figures/a.png"), b"png").unwrap();
        }
        // A directory named like a temporary file and a file named like a
        // staging directory are not ours.
        let dir_named_tmp = d.join(format!(".unfold-{dead}-z.tmp"));
        std::fs::create_dir(&dir_named_tmp).unwrap();
        let file_named_dir = d.join(format!(".o.unfold-{dead}-q.partial"));
        std::fs::write(&file_named_dir, b"x").unwrap();
        // Off Linux, liveness is by age.
        if !cfg!(target_os = "linux") {
            for p in [&stale_tmp, &stale_dir] {
                std::fs::File::open(p).unwrap().set_modified(old).unwrap();
            }
        }
        let mut removed = clean_stale(d);
        removed.sort();
        let mut want = vec![stale_tmp.clone(), stale_dir.clone()];
        want.sort();
        assert_eq!(removed, want);
        assert!(!stale_tmp.exists() && !stale_dir.exists());
        for kept in [&live_tmp, &user, &live_dir, &dir_named_tmp, &file_named_dir] {
            assert!(kept.exists(), "{}", kept.display());
        }
    }

    #[test]
    fn a_staging_dir_with_a_manifest_loses_only_its_listed_files() {
        let dir = tempfile::tempdir().unwrap();
        let s = dir.path().join(format!(".out.unfold-{}-m.old", dead_pid()));
        std::fs::create_dir_all(s.join("figures")).unwrap();
        std::fs::write(s.join("report.json"), b"{}").unwrap();
        std::fs::write(s.join("figures/a.png"), b"png").unwrap();
        std::fs::write(
            s.join(MANIFEST),
            br#"{"written_by":"unfold","files":["report.json","figures/a.png"]}"#,
        )
        .unwrap();
        // A file somebody added after the check: kept, and so is the
        // manifest and the directory holding it.
        std::fs::write(s.join("mine.txt"), b"keep").unwrap();
        assert!(clean_stale(dir.path()).is_empty());
        assert_eq!(std::fs::read(s.join("mine.txt")).unwrap(), b"keep");
        assert!(s.join(MANIFEST).exists());
        assert!(!s.join("report.json").exists() && !s.join("figures").exists());
        // Without it the rest goes.
        std::fs::remove_file(s.join("mine.txt")).unwrap();
        assert_eq!(clean_stale(dir.path()), vec![s.clone()]);
        assert!(!s.exists());
    }
}
