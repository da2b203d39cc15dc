//! The one place a file is read or written (`tests/architecture.rs` holds the rest of
//! `src/` to it). A file a user gives us is checked to be a regular file before it is
//! opened, since a FIFO or a device could block or never end: models and MTL libraries are
//! read whole ([`read_regular_file`]; glTF buffers to their declared length with
//! [`read_regular_prefix`]; a large model in parallel parts with
//! [`read_regular_file_parallel`]), presets with a bound ([`read_capped`]), textures and
//! environment maps through [`read_image`]. Every file we write whole goes through
//! [`write_atomic`], so that a failed write never leaves a half-written file or costs the
//! user the one that was there.
//!
//! Of ours it imports only `render_settings` (the largest PNG `image_files` reads).

pub mod image_files;

use std::fs::{self, File};
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

use anyhow::Context;

/// The size of `path` if it is a regular file (links followed); otherwise one sentence
/// naming `what` and why it cannot be read. Checked before opening: opening a FIFO or a
/// device for reading can block or never end.
pub(crate) fn regular_file_size(path: &Path, what: &str) -> Result<u64, String> {
    let meta = fs::metadata(path)
        .map_err(|e| format!("cannot read {what} {}: {}", shown_path(path), io_reason(&e)))?;
    if !meta.is_file() {
        return Err(format!("cannot read {what} {}: not a regular file", shown_path(path)));
    }
    Ok(meta.len())
}

/// The whole of a regular file of at most `cap` bytes; a bigger one, or anything that is
/// not a regular file, is one sentence naming `what`.
pub(crate) fn read_capped(path: &Path, what: &str, cap: u64) -> Result<Vec<u8>, String> {
    let size = regular_file_size(path, what)?;
    let too_big = || {
        format!(
            "cannot read {what} {}: larger than {} (a {what} is at most that)",
            shown_path(path),
            bytes_text(cap)
        )
    };
    if size > cap {
        return Err(too_big());
    }
    let file = File::open(path)
        .map_err(|e| format!("cannot read {what} {}: {}", shown_path(path), io_reason(&e)))?;
    // The size may change between the check and the read: read one byte past the cap.
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(cap + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("cannot read {what} {}: {}", shown_path(path), io_reason(&e)))?;
    if bytes.len() as u64 > cap {
        return Err(too_big());
    }
    Ok(bytes)
}

/// The bytes of a regular file. Devices and pipes are refused before they are opened:
/// `/dev/zero` would never end, and opening a FIFO waits for a writer.
pub(crate) fn read_regular_file(path: &Path) -> std::io::Result<Vec<u8>> {
    read_regular_prefix(path, u64::MAX)
}

/// The first `len` bytes of a regular file (all of it when shorter), refused as
/// [`read_regular_file`] refuses: a glTF buffer, whose declared length bounds what is read
/// and allocated, however large the file it names (or claims) is.
pub(crate) fn read_regular_prefix(path: &Path, len: u64) -> std::io::Result<Vec<u8>> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        let what = if meta.is_dir() { "a directory" } else { "not a regular file" };
        return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("it is {what}")));
    }
    let file = std::fs::File::open(path)?;
    let expected = usize::try_from(meta.len().min(len)).unwrap_or(0);
    let mut bytes = Vec::with_capacity(expected.saturating_add(1));
    file.take(len).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// [`read_regular_file`] with the reading split between threads (positioned reads of
/// disjoint parts, so the kernel's copying and the page faults of a large model file run
/// on every core). Only as many bytes as the file had when it was checked are read; a
/// file that changes meanwhile is read again the plain way.
pub(crate) fn read_regular_file_parallel(path: &Path) -> std::io::Result<Vec<u8>> {
    use rayon::prelude::*;
    /// Below this, one read: threads would cost more than they save.
    const PART: usize = 8 << 20;
    let meta = std::fs::metadata(path)?;
    let len = usize::try_from(meta.len()).unwrap_or(usize::MAX);
    if !cfg!(unix) || !meta.is_file() || len < 2 * PART {
        return read_regular_file(path);
    }
    let file = File::open(path)?;
    let mut bytes = vec![0u8; len];
    let parts: Vec<(usize, &mut [u8])> =
        bytes.chunks_mut(PART).enumerate().map(|(i, part)| (i * PART, part)).collect();
    if parts
        .into_par_iter()
        .try_for_each(|(offset, part)| read_exact_at(&file, part, offset as u64))
        .is_err()
    {
        // Shrunk since it was checked, or a read failed: the plain read says what is there.
        return read_regular_file(path);
    }
    // Grown since it was checked: the plain read takes what is there now.
    let mut probe = [0u8; 1];
    if read_at(&file, &mut probe, len as u64)? != 0 {
        return read_regular_file(path);
    }
    Ok(bytes)
}

#[cfg(unix)]
fn read_exact_at(file: &File, part: &mut [u8], offset: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(file, part, offset)
}

#[cfg(unix)]
fn read_at(file: &File, buf: &mut [u8], offset: u64) -> std::io::Result<usize> {
    std::os::unix::fs::FileExt::read_at(file, buf, offset)
}

#[cfg(not(unix))]
fn read_exact_at(_: &File, _: &mut [u8], _: u64) -> std::io::Result<()> {
    Err(std::io::Error::other("positioned reads are only used on Unix"))
}

#[cfg(not(unix))]
fn read_at(_: &File, _: &mut [u8], _: u64) -> std::io::Result<usize> {
    Err(std::io::Error::other("positioned reads are only used on Unix"))
}

/// Decode the image file at `path` (PNG, JPEG, TGA, HDR, EXR, DDS), refusing what is not a
/// regular file before opening it.
pub(crate) fn read_image(path: &Path, what: &str) -> Result<image::DynamicImage, String> {
    regular_file_size(path, what)?;
    image::open(path).map_err(|e| format!("cannot read {what} {}: {e}", shown_path(path)))
}

/// Makes a write past the file-size limit (`ulimit -f`) fail with "file too large" instead
/// of the system stopping the process at once: stopped, a write through [`write_atomic`]
/// would leave its temporary file behind and the user only the shell's "File size limit
/// exceeded". Called once, first thing in `main`. (A CPU Vulkan driver that outgrows the
/// limit still dies, of a bus error instead; `gpu::context` warns of the limit.)
pub fn ignore_file_size_signal() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: SIG_IGN installs no handler of ours; it only changes what the kernel does on
    // SIGXFSZ (the write then returns EFBIG), and no code of ours relies on that signal.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

/// Write `path` through `write`: into a temporary file beside it, synced, then renamed
/// over `path`. On any failure `path` is left as it was and the temporary is removed; the
/// error says "cannot write PATH: why".
pub(crate) fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let path_shown = shown_path(path);
    // A link is written through (the link stays, its file is replaced); a device, FIFO
    // or folder under the name is refused rather than replaced or written into.
    let path = &match fs::metadata(path) {
        Ok(meta) if !meta.is_file() => {
            anyhow::bail!("cannot write {path_shown}: it is not a regular file")
        }
        Ok(_) => fs::canonicalize(path).with_context(|| format!("cannot write {path_shown}"))?,
        Err(_) => path.to_path_buf(),
    };
    let tmp = temporary_beside(path);
    let result = (|| -> anyhow::Result<()> {
        let mut out = BufWriter::new(File::create(&tmp)?);
        write(&mut out)?;
        let file = out.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        fs::rename(&tmp, path)?;
        Ok(())
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    // "file too large", not Rust's "File too large (os error 27)".
    let result = result.map_err(|e| {
        let os_error = e
            .chain()
            .filter_map(|cause| cause.downcast_ref::<std::io::Error>())
            .find(|io| io.raw_os_error().is_some());
        match os_error {
            Some(io) => anyhow::anyhow!(io_reason(io)),
            None => e,
        }
    });
    result.with_context(|| format!("cannot write {path_shown}"))
}

/// Check, before a long render, that `path` can be written: its folder exists and takes a
/// new file (one is made and removed), and `path` is absent or a regular file (a folder, a
/// FIFO or a device is refused now, not by [`write_atomic`] after the work; only its
/// metadata is read, so a FIFO is never opened).
pub(crate) fn check_writable(path: &Path) -> anyhow::Result<()> {
    let check = || -> std::io::Result<()> {
        if let Ok(meta) = fs::metadata(path) {
            let kind = std::io::ErrorKind::InvalidInput;
            if meta.is_dir() {
                return Err(std::io::Error::new(kind, "it is a folder"));
            }
            if !meta.is_file() {
                return Err(std::io::Error::new(kind, "it is not a regular file"));
            }
        }
        let tmp = temporary_beside(path);
        File::create(&tmp)?;
        fs::remove_file(&tmp)
    };
    check().map_err(|e| anyhow::anyhow!("cannot write {}: {}", shown_path(path), io_reason(&e)))
}

/// Write `bytes` to `path` as [`write_atomic`] does.
pub(crate) fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    write_atomic(path, |out| Ok(out.write_all(bytes)?))
}

/// A text file of ours (remembered settings, a saved report): [`read_regular_file`] as
/// UTF-8, so a missing file is still `NotFound` to the caller.
pub(crate) fn read_text(path: &Path) -> std::io::Result<String> {
    String::from_utf8(read_regular_file(path)?)
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidData, "it is not UTF-8 text"))
}

/// A file written as it goes (a log a reader may follow), not through [`write_atomic`]:
/// a failure leaves the rows written so far.
pub(crate) type LogFile = BufWriter<File>;

/// Create (or empty) `path` as a [`LogFile`].
pub(crate) fn create_log(path: &Path) -> std::io::Result<LogFile> {
    Ok(BufWriter::new(File::create(path)?))
}

/// Append `line` and a newline to `path`, creating it if missing (JSON Lines: a run
/// added to the runs before it, which a whole-file rewrite could lose).
pub(crate) fn append_line(path: &Path, line: &str) -> std::io::Result<()> {
    let mut file = fs::OpenOptions::new().create(true).append(true).open(path)?;
    writeln!(file, "{line}")
}

/// Create the folder `dir` and those above it that are missing.
pub(crate) fn create_folder(dir: &Path) -> std::io::Result<()> {
    fs::create_dir_all(dir)
}

/// Remove the file `path`.
pub(crate) fn remove_file(path: &Path) -> std::io::Result<()> {
    fs::remove_file(path)
}

/// `path` made absolute with links resolved, or as given when that fails (it does not
/// exist yet): for telling the user where a file is.
pub(crate) fn canonical_or_given(path: &Path) -> PathBuf {
    fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

/// When `path` was last modified; None when that cannot be read.
pub(crate) fn modified(path: &Path) -> Option<std::time::SystemTime> {
    fs::metadata(path).and_then(|m| m.modified()).ok()
}

/// The text of a Linux kernel file (`/proc/self/status`), at most 64 KiB of it; None
/// where there is none (off Linux).
pub(crate) fn read_proc_file(path: &Path) -> Option<String> {
    let mut text = String::new();
    File::open(path).ok()?.take(64 << 10).read_to_string(&mut text).ok()?;
    Some(text)
}

/// Write `text` to a Linux kernel file (`/proc/self/clear_refs`): a setting, not a file
/// to keep, so written in place.
pub(crate) fn write_proc_file(path: &Path, text: &str) -> std::io::Result<()> {
    fs::write(path, text)
}

/// Text quoted from a file, made safe for a terminal or the panel: control characters
/// (escape sequences, bells, carriage returns) written as `\u{1b}`, and anything past
/// `max` characters cut to "...".
pub(crate) fn shown(text: &str, max: usize) -> String {
    let mut out = String::new();
    for (i, c) in text.chars().enumerate() {
        if i == max {
            out.push_str("...");
            break;
        }
        if c.is_control() {
            out.extend(c.escape_unicode());
        } else {
            out.push(c);
        }
    }
    out
}

/// The longest name (a material, a file named inside a file) quoted in a message.
pub(crate) const MAX_QUOTED_NAME: usize = 200;

/// The longest path quoted in a message: longer ones are cut, so that a path made of a whole
/// file's text never makes a megabyte error line.
pub(crate) const MAX_QUOTED_PATH: usize = 1000;

/// A path as a message shows it: like [`shown`], since a path given on the command line or
/// named inside a file may hold escape sequences that would act on the terminal.
pub(crate) fn shown_path(path: &Path) -> String {
    shown(&path.to_string_lossy(), MAX_QUOTED_PATH)
}

/// A hidden name in `path`'s folder, unique to this process and call.
fn temporary_beside(path: &Path) -> PathBuf {
    use std::sync::atomic::{AtomicU32, Ordering};
    static NEXT: AtomicU32 = AtomicU32::new(0);
    let name = path.file_name().map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    let unique =
        format!(".{name}.{}-{}.tmp", std::process::id(), NEXT.fetch_add(1, Ordering::Relaxed));
    path.with_file_name(unique)
}

/// An I/O error's reason without Rust's "(os error 2)" suffix.
pub(crate) fn io_reason(e: &std::io::Error) -> String {
    let text = e.to_string();
    match text.find(" (os error") {
        Some(i) => text[..i].to_lowercase(),
        None => text,
    }
}

/// "1 MiB", "512 KiB", "300 bytes".
fn bytes_text(n: u64) -> String {
    match n {
        n if n >= 1 << 20 && n % (1 << 20) == 0 => format!("{} MiB", n >> 20),
        n if n >= 1 << 10 && n % (1 << 10) == 0 => format!("{} KiB", n >> 10),
        n => format!("{n} bytes"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("meshtracer-files-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_leaves_no_temporary() {
        let dir = temp_dir("atomic");
        let path = dir.join("x.txt");
        fs::write(&path, b"old").unwrap();
        let err = write_atomic(&path, |out| {
            out.write_all(b"half")?;
            anyhow::bail!("disk full")
        })
        .unwrap_err();
        assert!(
            format!("{err:#}").starts_with(&format!("cannot write {}: disk full", path.display())),
            "{err:#}"
        );
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 1, "no temporary left behind");
        write_bytes_atomic(&path, b"new").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new");
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 1);
        // Through a link: the link stays and its file changes; a device is refused.
        let link = dir.join("link.txt");
        std::os::unix::fs::symlink(&path, &link).unwrap();
        write_bytes_atomic(&link, b"via link").unwrap();
        assert!(fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(fs::read(&path).unwrap(), b"via link");
        let full = dir.join("full.exr");
        std::os::unix::fs::symlink("/dev/full", &full).unwrap();
        let err = write_bytes_atomic(&full, b"x").unwrap_err().to_string();
        assert!(err.ends_with("it is not a regular file"), "{err}");
        assert!(fs::symlink_metadata(&full).unwrap().file_type().is_symlink(), "the link is kept");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_path_in_an_error_is_escaped_and_cut() {
        // A path from the command line with a terminal escape (a title change, a clear).
        let hostile = std::path::PathBuf::from("/no/such/\u{1b}]0;PWNED\u{7}\u{1b}[2J.obj");
        let err = regular_file_size(&hostile, "model").unwrap_err();
        assert!(!err.chars().any(char::is_control), "{err:?}");
        assert!(err.contains("\\u{1b}]0;PWNED"), "{err:?}");
        let long = std::path::PathBuf::from("x".repeat(100_000));
        let err = read_capped(&long, "model", 10).unwrap_err();
        assert!(err.len() < 2 * MAX_QUOTED_PATH, "{} bytes", err.len());
    }

    #[test]
    fn quoted_text_is_cut_and_its_control_characters_escaped() {
        assert_eq!(shown("a\x1b]0;title\x07b", 100), "a\\u{1b}]0;title\\u{7}b");
        assert_eq!(shown(&"x".repeat(1000), 5), "xxxxx...");
        assert_eq!(shown("ünïcode", 100), "ünïcode");
    }

    #[test]
    fn an_unwritable_output_is_found_before_the_work() {
        let dir = temp_dir("writable");
        assert!(check_writable(&dir.join("x.png")).is_ok());
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 0, "the probe is removed");
        let e = check_writable(&dir.join("missing/x.png")).unwrap_err().to_string();
        assert!(e.contains("missing/x.png") && e.ends_with("no such file or directory"), "{e}");
        assert!(check_writable(&dir).unwrap_err().to_string().ends_with("it is a folder"));
        let e = check_writable(Path::new("/dev/null")).unwrap_err().to_string();
        assert!(e.ends_with("it is not a regular file"), "{e}");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn reads_are_capped_and_only_of_regular_files() {
        let dir = temp_dir("capped");
        let path = dir.join("p.toml");
        fs::write(&path, vec![b'a'; 100]).unwrap();
        assert_eq!(read_capped(&path, "preset", 100).unwrap().len(), 100);
        let err = read_capped(&path, "preset", 99).unwrap_err();
        assert!(err.contains("larger than 99 bytes"), "{err}");
        let err = read_capped(&dir, "preset", 1 << 20).unwrap_err();
        assert!(err.ends_with("not a regular file"), "{err}");
        let err = read_capped(&dir.join("none"), "preset", 1 << 20).unwrap_err();
        assert!(err.ends_with("no such file or directory"), "{err}");
        fs::remove_dir_all(&dir).unwrap();
    }
}
