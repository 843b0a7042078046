//! Atomic file writes (design.md: nothing is lost): write a temporary file beside the target, flush it
//! to disk, then rename it over the target, so readers see the old file or the new one, never half.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// The temporary name used while writing `path` (same directory, so the rename is atomic).
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp{}", std::process::id()))
}

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_atomic_with(path, |tmp| {
        let mut f = std::fs::File::create(tmp)?;
        f.write_all(bytes)?;
        f.sync_all()
    })
}

/// Lets `write` create the file at the temporary path it is given, then renames it to `path`. On
/// failure the temporary file is removed and the target is untouched.
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&Path) -> std::io::Result<()>,
) -> std::io::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let tmp = temp_path(path);
    match write(&tmp).and_then(|()| std::fs::rename(&tmp, path)) {
        Ok(()) => Ok(()),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// How old a temporary file must be before [`sweep_stale_temps`] takes it for the leftover of a
/// killed process: writes take seconds, so an hour leaves any write in progress alone, also one of
/// another process sharing the directory.
pub const STALE_AFTER: Duration = Duration::from_secs(3600);

/// Whether `name` is one of [`temp_path`]'s names: `.NAME.tmpPID`.
fn is_temp_name(name: &str) -> bool {
    name.starts_with('.')
        && name.rsplit_once(".tmp").is_some_and(|(stem, pid)| {
            stem.len() > 1 && !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit())
        })
}

/// Removes the temporary files that writes interrupted by a kill or a crash left in `dir` and its
/// subdirectories (an interrupted write removes its own; these are the ones nothing could), if they
/// were last modified more than `min_age` ago. Returns how many it removed; a missing `dir` has
/// none.
pub fn sweep_stale_temps(dir: &Path, min_age: Duration) -> std::io::Result<usize> {
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(e),
    };
    let now = SystemTime::now();
    let mut removed = 0;
    for entry in entries {
        let entry = entry?;
        let kind = entry.file_type()?;
        if kind.is_dir() {
            removed += sweep_stale_temps(&entry.path(), min_age)?;
        } else if kind.is_file() && is_temp_name(&entry.file_name().to_string_lossy()) {
            let modified = entry.metadata()?.modified()?;
            if now.duration_since(modified).is_ok_and(|age| age > min_age) {
                std::fs::remove_file(entry.path())?;
                removed += 1;
            }
        }
    }
    Ok(removed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stale_temporary_files_are_swept_and_nothing_else() {
        let dir = std::env::temp_dir().join(format!("lightlab-sweep-{}", std::process::id()));
        let runs = dir.join("runs").join("a");
        std::fs::create_dir_all(&runs).unwrap();
        let old = SystemTime::now() - Duration::from_secs(2 * 3600);
        let write = |path: &Path, modified: SystemTime| {
            let f = std::fs::File::create(path).unwrap();
            f.set_modified(modified).unwrap();
        };
        let stale = [
            temp_path(&dir.join("runs.csv")),
            temp_path(&runs.join("metrics.json")),
        ];
        for p in &stale {
            write(p, old);
        }
        // A write in progress, a finished file, and names that only look alike are kept.
        let kept = [
            temp_path(&runs.join("image.exr")),
            runs.join("metrics.json"),
            dir.join(".tmp123"),
            dir.join(".a.tmp"),
            dir.join(".a.tmp12x"),
            dir.join("a.tmp12"),
        ];
        write(&kept[0], SystemTime::now());
        for p in &kept[1..] {
            write(p, old);
        }
        assert_eq!(sweep_stale_temps(&dir, STALE_AFTER).unwrap(), 2);
        assert!(stale.iter().all(|p| !p.exists()));
        assert!(kept.iter().all(|p| p.exists()));
        assert_eq!(
            sweep_stale_temps(&dir.join("missing"), STALE_AFTER).unwrap(),
            0
        );
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn failed_write_leaves_target_untouched() {
        let dir = std::env::temp_dir().join(format!("lightlab-atomic-{}", std::process::id()));
        let target = dir.join("a.txt");
        write_atomic(&target, b"old").unwrap();
        let err = write_atomic_with(&target, |tmp| {
            std::fs::write(tmp, b"half")?;
            Err(std::io::Error::other("interrupted"))
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        assert!(!temp_path(&target).exists());
        write_atomic(&target, b"new").unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        std::fs::remove_dir_all(dir).unwrap();
    }
}
