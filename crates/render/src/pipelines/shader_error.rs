//! The error every shader problem becomes: where it is (`file:line:column`, against the file
//! the user edited, never against composed text) and what it is.

/// A shader that failed to load, compose, validate or compile: `file:line:column: message`, or
/// `file: message` for a problem without a place in the file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}{}: {message}", if *.line > 0 { format!(":{line}:{column}") } else { String::new() })]
pub struct ShaderError {
    pub file: String,
    /// 1-based; 0 when the problem has no position (a missing file).
    pub line: u32,
    pub column: u32,
    pub message: String,
}

impl ShaderError {
    pub fn whole_file(file: &str, message: impl Into<String>) -> Self {
        Self { file: file.to_owned(), line: 0, column: 0, message: message.into() }
    }

    /// wgpu's validation error for `file`'s module or pipeline, on one line for the log and the
    /// viewer's overlay.
    pub fn from_wgpu(file: &str, e: &wgpu::Error) -> Self {
        Self::whole_file(file, wgpu_error_line(e))
    }
}

/// A wgpu error as one line: its causes joined with ": ", without the "Validation Error" heading
/// and the context line naming the call and its label (for a pipeline, the whole key).
pub(crate) fn wgpu_error_line(e: &wgpu::Error) -> String {
    // wgpu's context: "In Device::create_render_pipeline[, label = '…']".
    let is_context = |text: &str| {
        text.strip_prefix("In ").and_then(|rest| rest.split([',', ' ']).next()).is_some_and(|call| call.contains("::"))
    };
    let one_line = |text: &str| text.split_whitespace().collect::<Vec<_>>().join(" ");
    let mut causes = Vec::new();
    let mut cause = std::error::Error::source(e);
    while let Some(c) = cause {
        let text = c.to_string();
        if !is_context(&text) {
            causes.push(one_line(&text));
        }
        cause = c.source();
    }
    if causes.is_empty() { one_line(&e.to_string()) } else { causes.join(": ") }
}
