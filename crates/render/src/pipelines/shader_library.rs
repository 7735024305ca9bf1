//! The shader library: WGSL sources embedded at compile time from the top-level `shaders/`
//! folder, validated with naga before any GPU module is created, so a broken shader is reported
//! as `file:line:column: message` instead of failing inside the driver. Hot reload and
//! composition (issue #7) will extend this module; the rest of the renderer only asks it for
//! modules by name.

use std::collections::HashMap;

/// The shaders compiled into the binary: (file name, source).
pub const EMBEDDED: &[(&str, &str)] = &[
    ("forward.wgsl", include_str!("../../../../shaders/forward.wgsl")),
    ("tonemap.wgsl", include_str!("../../../../shaders/tonemap.wgsl")),
    ("mipmap.wgsl", include_str!("../../../../shaders/mipmap.wgsl")),
];

#[derive(Debug, thiserror::Error)]
#[error("{file}:{line}:{column}: {message}")]
pub struct ShaderError {
    pub file: String,
    pub line: u32,
    pub column: u32,
    pub message: String,
}

/// Parses and validates WGSL with naga; errors carry the first label's position.
pub fn validate(file: &str, source: &str) -> Result<naga::Module, ShaderError> {
    let located = |message: String, loc: Option<naga::SourceLocation>| ShaderError {
        file: file.to_owned(),
        line: loc.map_or(0, |l| l.line_number),
        column: loc.map_or(0, |l| l.line_position),
        message,
    };
    let module =
        naga::front::wgsl::parse_str(source).map_err(|e| located(e.message().to_owned(), e.location(source)))?;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| {
            let loc = e.spans().next().map(|(span, _)| span.location(source));
            located(e.as_inner().to_string(), loc)
        })?;
    Ok(module)
}

pub struct ShaderLibrary {
    modules: HashMap<&'static str, wgpu::ShaderModule>,
}

impl ShaderLibrary {
    pub fn new(device: &wgpu::Device) -> Result<Self, ShaderError> {
        let mut modules = HashMap::new();
        for &(file, source) in EMBEDDED {
            validate(file, source)?;
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(file),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
            modules.insert(file, module);
        }
        Ok(Self { modules })
    }

    pub fn get(&self, file: &str) -> &wgpu::ShaderModule {
        self.modules.get(file).unwrap_or_else(|| panic!("{file} is not an embedded shader"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_embedded_shader_validates() {
        for &(file, source) in EMBEDDED {
            if let Err(e) = validate(file, source) {
                panic!("{e}");
            }
        }
    }

    #[test]
    fn syntax_errors_report_file_line_and_column() {
        let err = validate("broken.wgsl", "fn main() {\n  let x = ;\n}").unwrap_err();
        assert_eq!((err.file.as_str(), err.line), ("broken.wgsl", 2), "{err}");
        assert!(err.column > 0);
    }
}
