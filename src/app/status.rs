//! A one-line report to the user (a file written, a reload failed), shown by the panel's
//! status lines; below every folder of the app, so the parts that act (measure, files) can
//! report without knowing the panel.

/// A status line: text and whether it reports a failure.
#[derive(Clone, Debug, Default)]
pub(crate) struct Status {
    pub(crate) text: String,
    pub(crate) error: bool,
}

impl Status {
    /// A line that reports success.
    pub(crate) fn ok(text: impl Into<String>) -> Self {
        Self { text: text.into(), error: false }
    }
    /// A line that reports a failure (drawn red).
    pub(crate) fn error(text: impl Into<String>) -> Self {
        Self { text: text.into(), error: true }
    }
}
