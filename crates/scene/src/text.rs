//! Reading the text files Lightlab is given (scenes, experiments, OBJ meshes): a size limit, so
//! that a device or an endless pipe named by mistake is refused instead of read until memory runs
//! out, and the line and column of a byte that is not UTF-8.

use std::io::Read;
use std::path::Path;

/// Longest text file read: 4 GiB, as for images (an OBJ file of 4 GiB holds some 50 million
/// triangles; a scene or experiment file is a few kilobytes).
pub const MAX_TEXT_BYTES: u64 = 4 << 30;

/// Why a text file could not be read.
#[derive(Debug)]
pub enum TextError {
    Io(std::io::Error),
    /// The file holds more than [`MAX_TEXT_BYTES`].
    TooLarge,
    /// The byte at 1-based `line` and `col` (in characters) starts no UTF-8 character.
    NotUtf8 {
        line: usize,
        col: usize,
        byte: u8,
    },
}

impl std::fmt::Display for TextError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TextError::Io(e) => write!(f, "cannot read the file: {e}"),
            TextError::TooLarge => write!(
                f,
                "the file holds more than {} GiB, the most a text file may hold (is it a device \
                 or an endless pipe?)",
                MAX_TEXT_BYTES >> 30
            ),
            // The position is the caller's to print (`located`, or a scene error's own).
            TextError::NotUtf8 { byte, .. } => write!(
                f,
                "byte 0x{byte:02x} is not UTF-8 text (save the file as UTF-8)"
            ),
        }
    }
}

impl TextError {
    /// The error as `path:line:col: message` (or `path: message`), the form every file error
    /// takes.
    pub fn located(&self, path: &Path) -> String {
        match self {
            TextError::NotUtf8 { line, col, .. } => {
                format!("{}:{line}:{col}: {self}", path.display())
            }
            _ => format!("{}: {self}", path.display()),
        }
    }
}

impl std::error::Error for TextError {}

/// The contents of the text file at `path`, at most [`MAX_TEXT_BYTES`].
pub fn read_text(path: &Path) -> Result<String, TextError> {
    read_at_most(path, MAX_TEXT_BYTES)
}

fn read_at_most(path: &Path, limit: u64) -> Result<String, TextError> {
    let file = std::fs::File::open(path).map_err(TextError::Io)?;
    let mut bytes = Vec::new();
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(TextError::Io)?;
    if bytes.len() as u64 > limit {
        return Err(TextError::TooLarge);
    }
    String::from_utf8(bytes).map_err(|e| {
        let bytes = e.as_bytes();
        let valid = e.utf8_error().valid_up_to();
        // Everything before the bad byte is valid UTF-8.
        let before = std::str::from_utf8(&bytes[..valid]).unwrap_or_default();
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        TextError::NotUtf8 {
            line: before.matches('\n').count() + 1,
            col: before[line_start..].chars().count() + 1,
            byte: bytes[valid],
        }
    })
}

/// `text` with its RON comments (`//` to the end of the line, `/* … */`, nested) blanked to
/// spaces byte for byte, newlines kept: searching it for a field's name finds the field, not a
/// comment that mentions it, at the same byte offset as in `text`.
pub fn without_comments(text: &str) -> String {
    #[derive(PartialEq)]
    enum State {
        Code,
        Str { escaped: bool },
        Line,
        Block(u32),
    }
    let bytes = text.as_bytes();
    let mut out = bytes.to_vec();
    let mut state = State::Code;
    let mut i = 0;
    while i < bytes.len() {
        let (b, next) = (bytes[i], bytes.get(i + 1).copied());
        let blank = |out: &mut Vec<u8>, at: usize| {
            if out[at] != b'\n' {
                out[at] = b' ';
            }
        };
        match state {
            State::Code => match (b, next) {
                (b'"', _) => state = State::Str { escaped: false },
                (b'/', Some(b'/')) => state = State::Line,
                (b'/', Some(b'*')) => {
                    state = State::Block(1);
                    blank(&mut out, i);
                    blank(&mut out, i + 1);
                    i += 1;
                }
                _ => {}
            },
            State::Str { escaped } => {
                state = match b {
                    b'"' if !escaped => State::Code,
                    b'\\' => State::Str { escaped: !escaped },
                    _ => State::Str { escaped: false },
                }
            }
            State::Line => {
                if b == b'\n' {
                    state = State::Code;
                }
            }
            State::Block(depth) => match (b, next) {
                (b'*', Some(b'/')) => {
                    state = if depth == 1 {
                        State::Code
                    } else {
                        State::Block(depth - 1)
                    };
                    blank(&mut out, i);
                    blank(&mut out, i + 1);
                    i += 2;
                    continue;
                }
                (b'/', Some(b'*')) => {
                    state = State::Block(depth + 1);
                    blank(&mut out, i);
                    blank(&mut out, i + 1);
                    i += 2;
                    continue;
                }
                _ => {}
            },
        }
        if matches!(state, State::Line | State::Block(_)) {
            blank(&mut out, i);
        }
        i += 1;
    }
    // Only ASCII bytes were written, each over a whole comment's bytes: still UTF-8.
    String::from_utf8(out).expect("comments blanked whole")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("lightlab-text-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    #[test]
    fn a_byte_that_is_not_utf8_is_located() {
        let path = temp("latin1.ron", b"Scene(\n  // caf\xc3\xa9 \xe9t\xe9\n)");
        match read_text(&path) {
            Err(TextError::NotUtf8 { line, col, byte }) => {
                assert_eq!((line, col, byte), (2, 11, 0xe9));
            }
            other => panic!("{other:?}"),
        }
        let path = temp("first.ron", b"\xffScene()");
        assert!(matches!(
            read_text(&path),
            Err(TextError::NotUtf8 {
                line: 1,
                col: 1,
                byte: 0xff
            })
        ));
        let path = temp("fine.ron", "Scene(// café\n)".as_bytes());
        assert_eq!(read_text(&path).unwrap(), "Scene(// café\n)");
    }

    /// An endless device is read up to the limit and refused (a 1 MiB limit here; the real one
    /// is 4 GiB); a file of exactly the limit is read.
    #[cfg(unix)]
    #[test]
    fn an_endless_device_is_refused_at_the_limit() {
        assert!(matches!(
            read_at_most(Path::new("/dev/zero"), 1 << 20),
            Err(TextError::TooLarge)
        ));
        let path = temp("exact.ron", &[b' '; 1 << 10]);
        assert_eq!(read_at_most(&path, 1 << 10).unwrap().len(), 1 << 10);
        assert!(matches!(
            read_at_most(&path, (1 << 10) - 1),
            Err(TextError::TooLarge)
        ));
    }

    #[test]
    fn comments_are_blanked_in_place() {
        let text = "Scene( // trials: é\n  a: \"x // y\", /* b /* c */ d */ trials: 2,\n)";
        let out = without_comments(text);
        assert_eq!(out.len(), text.len());
        assert_eq!(out.find("trials"), text.rfind("trials"));
        assert!(out.contains("\"x // y\""), "{out}");
        assert!(
            !out.contains('b') && !out.contains('d') && out.contains('\n'),
            "{out}"
        );
        assert_eq!(out.lines().count(), text.lines().count());
    }
}
