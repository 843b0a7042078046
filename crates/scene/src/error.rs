//! Scene loading errors: every message names the file, and where it can, the line and column.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{}: cannot read the file: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}:{line}:{col}: {message}", path.display())]
    Invalid {
        path: PathBuf,
        line: usize,
        col: usize,
        message: String,
    },
}

impl SceneError {
    /// The error of reading the text file `path`.
    pub(crate) fn reading(path: &std::path::Path, e: crate::text::TextError) -> SceneError {
        use crate::text::TextError;
        let path = path.to_path_buf();
        match e {
            TextError::Io(source) => SceneError::Io { path, source },
            TextError::NotUtf8 { line, col, .. } => SceneError::Invalid {
                path,
                line,
                col,
                message: e.to_string(),
            },
            TextError::TooLarge => SceneError::Io {
                path,
                source: std::io::Error::other(e),
            },
        }
    }

    /// An error at the first occurrence of `needle` in `text` (1:1 if absent).
    pub(crate) fn at(
        path: &std::path::Path,
        text: &str,
        needle: &str,
        message: String,
    ) -> SceneError {
        let (line, col) = locate(text, needle).unwrap_or((1, 1));
        SceneError::Invalid {
            path: path.to_path_buf(),
            line,
            col,
            message,
        }
    }
}

/// 1-based line and column (in characters) of the first occurrence of `needle` outside comments.
pub(crate) fn locate(text: &str, needle: &str) -> Option<(usize, usize)> {
    crate::text::without_comments(text)
        .find(needle)
        .map(|at| line_col(text, at))
}

/// 1-based line and column (in characters) of byte offset `at` of `text`.
pub(crate) fn line_col(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}
