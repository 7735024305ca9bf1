//! The shader library: WGSL sources, their composition into modules, and their replacement at
//! run time.
//!
//! - Sources: the files of the top-level `shaders/` folder, embedded at compile time; or the
//!   same files read from a folder on disk (`--shader-dir`, or the repository's own folder when
//!   the viewer runs from it), which [`super::shader_watcher`] watches.
//! - Composition: files that declare `#define_import_path` are composable modules, imported by
//!   entry files (`forward.wgsl`, `tonemap.wgsl`, `mipmap.wgsl`) with `#import`; `#ifdef`
//!   switches are resolved per variant ([`ShaderDefs`]) before compilation, so a variant's module
//!   contains only the code it uses. naga_oil (Bevy's composer, built on naga 30) does both and
//!   validates the result with naga. A switch no variant defines is refused as a typo before
//!   composition ([`super::feature_switches`]).
//! - Errors are `file:line:column: message` against the file the user edited, never against
//!   composed text.
//! - A library is immutable once built: a reload builds a candidate library from the new sources
//!   and the pipeline cache swaps it in only if every affected pipeline compiles with it.

use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::{Arc, LazyLock, Mutex};

use super::feature_switches::{self, FEATURE_SWITCHES};
pub use super::shader_error::ShaderError;
use naga_oil::compose::preprocess::Preprocessor;
use naga_oil::compose::{
    ComposableModuleDescriptor, Composer, ComposerError, ComposerErrorInner, NagaModuleDescriptor, ShaderDefValue,
    ShaderLanguage, ShaderType, get_preprocessor_data,
};

/// naga_oil's own preprocessor (its regular expressions compiled once), to find which modules a
/// variant brings in exactly as composition will: [`ShaderLibrary::variant_uses`].
static PREPROCESSOR: LazyLock<Preprocessor> = LazyLock::new(Preprocessor::default);

/// The shaders compiled into the binary, every `*.wgsl` of the repository's shader folder (the
/// build script lists them): (file name, source), by name.
pub const EMBEDDED: &[(&str, &str)] = include!(concat!(env!("OUT_DIR"), "/embedded_shaders.rs"));

/// The repository's shader folder as seen at compile time; the viewer watches it when it still
/// exists at run time (running from a checkout).
pub const REPOSITORY_SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shaders");

/// The feature switches of one variant: the `#ifdef` names that are defined.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ShaderDefs(pub BTreeSet<&'static str>);

impl ShaderDefs {
    pub fn with(mut self, def: &'static str, on: bool) -> Self {
        debug_assert!(FEATURE_SWITCHES.contains(&def), "{def} is missing from FEATURE_SWITCHES");
        if on {
            self.0.insert(def);
        }
        self
    }

    fn to_naga_oil(&self) -> HashMap<String, ShaderDefValue> {
        self.0.iter().map(|d| (d.to_string(), ShaderDefValue::Bool(true))).collect()
    }
}

impl fmt::Display for ShaderDefs {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let defs: Vec<&str> = self.0.iter().copied().collect();
        write!(f, "[{}]", defs.join(", "))
    }
}

/// Turns naga_oil's report (a codespan diagnostic) into `file:line:column: message`.
fn composer_error(e: &ComposerError, composer: &Composer, fallback_file: &str) -> ShaderError {
    let report = e.emit_to_string(composer);
    let message = report
        .lines()
        .find_map(|l| l.trim().strip_prefix("error: "))
        .map_or_else(|| e.inner.to_string(), str::to_owned);
    // codespan marks the primary location as "┌─ path:line:column".
    let location = report.lines().find_map(|l| l.trim().strip_prefix("┌─ ")).and_then(|loc| {
        let mut parts = loc.rsplitn(3, ':');
        let column = parts.next()?.trim().parse().ok()?;
        let line = parts.next()?.trim().parse().ok()?;
        Some((parts.next()?.to_owned(), line, column))
    });
    // naga_oil's report leaves out a WGSL parse error's own notes, which can hold the reason
    // ("internal WGSL front end error": "Parser recursion limit exceeded").
    let parse_notes: Vec<&str> = match &e.inner {
        ComposerErrorInner::WgslParseError(parse) => parse.notes().collect(),
        _ => Vec::new(),
    };
    // naga often repeats the headline as a note; keep only notes that add something.
    let mut notes: Vec<&str> = report.lines().filter_map(|l| l.trim().strip_prefix("= ")).collect();
    for note in parse_notes {
        if !notes.contains(&note) {
            notes.push(note);
        }
    }
    notes.retain(|n| *n != message);
    let message = if notes.is_empty() { message } else { format!("{message} ({})", notes.join("; ")) };
    match location {
        Some((file, line, column)) => ShaderError { file, line, column, message },
        None => ShaderError::whole_file(fallback_file, message),
    }
}

/// The embedded library being built by [`ShaderLibrary::preload_embedded`], taken by the next
/// [`ShaderLibrary::embedded`].
type Preload = std::thread::JoinHandle<Result<ShaderLibrary, ShaderError>>;
static PRELOADED: Mutex<Option<Preload>> = Mutex::new(None);

/// Sources and their composer. Cheap to rebuild: a handful of files.
pub struct ShaderLibrary {
    dir: Option<PathBuf>,
    sources: BTreeMap<String, String>,
    /// Module path (`penumbra::brdf`) to the file declaring it.
    module_files: HashMap<String, String>,
    /// File to the module paths it imports.
    imports: HashMap<String, Vec<String>>,
    /// Holds the composable modules (and the variants of them composed so far). Shared with the
    /// library a reload replaces when no module changed: the modules are then the same, so the
    /// candidate needs no composer of its own (building one parses every module again).
    composer: Arc<Mutex<Composer>>,
    /// The entry files this library has composed: a reload checks a changed entry that no
    /// pipeline in use composed (a pass the scene does not run) in its plain variant.
    composed: HashSet<String>,
}

impl ShaderLibrary {
    /// The embedded shaders: the library [`ShaderLibrary::preload_embedded`] started, if one is
    /// under way, else a new one.
    pub fn embedded() -> Result<Self, ShaderError> {
        let preloaded = PRELOADED.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take();
        if let Some(Ok(library)) = preloaded.map(std::thread::JoinHandle::join) {
            return library;
        }
        Self::build_embedded()
    }

    /// Starts building the embedded library on a thread of its own, for the next
    /// [`ShaderLibrary::embedded`] (a renderer's): parsing every module takes tens of
    /// milliseconds, which a program can overlap with the GPU's start-up and its scene's loading.
    pub fn preload_embedded() {
        let mut slot = PRELOADED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if slot.is_none() {
            *slot = Some(std::thread::spawn(Self::build_embedded));
        }
    }

    fn build_embedded() -> Result<Self, ShaderError> {
        let sources = EMBEDDED.iter().map(|(f, s)| (f.to_string(), s.to_string())).collect();
        Self::from_sources(None, sources)
    }

    /// The embedded shaders with `file`'s source replaced by `source` (an edit, as a reload would
    /// see it, without a folder): for tests and the composer's fuzz target.
    pub fn embedded_with(file: &str, source: &str) -> Result<Self, ShaderError> {
        let mut sources: BTreeMap<String, String> =
            EMBEDDED.iter().map(|(f, s)| (f.to_string(), s.to_string())).collect();
        sources.insert(file.to_owned(), source.to_owned());
        Self::from_sources(None, sources)
    }

    /// Every `*.wgsl` in `dir`; files missing there are taken from the embedded set.
    pub fn from_dir(dir: &Path) -> Result<Self, ShaderError> {
        Self::from_sources(Some(dir.to_path_buf()), read_folder(dir)?)
    }

    fn from_sources(dir: Option<PathBuf>, sources: BTreeMap<String, String>) -> Result<Self, ShaderError> {
        let mut module_files = HashMap::new();
        let mut imports = HashMap::new();
        feature_switches::check(&sources)?;
        for (file, source) in &sources {
            let (name, file_imports, _) = get_preprocessor_data(source);
            if let Some(name) = name {
                // Two files declaring one module (a backup copy left in the folder): whichever
                // won, edits to the other would change nothing, without a word.
                if let Some(first) = module_files.insert(name.clone(), file.clone()) {
                    return Err(ShaderError::whole_file(
                        file,
                        format!("declares module {name}, which {first} declares too (one file per module)"),
                    ));
                }
            }
            imports.insert(file.clone(), file_imports.into_iter().map(|i| i.import).collect::<Vec<_>>());
        }
        // 64-bit integers and their atomic min/max: the visibility buffer (visibility_raster.wgsl),
        // compiled only where the adapter has them (`Capabilities::visibility_raster`).
        let mut composer = Composer::default().with_capabilities(
            naga::valid::Capabilities::default()
                | naga::valid::Capabilities::SHADER_INT64
                | naga::valid::Capabilities::SHADER_INT64_ATOMIC_MIN_MAX,
        );
        // naga_oil wants every import registered before its importers: add in dependency order.
        let mut pending: Vec<&String> = module_files.values().collect();
        pending.sort();
        while !pending.is_empty() {
            let ready = pending.iter().position(|file| {
                imports[*file].iter().all(|m| composer.contains_module(m) || !module_files.contains_key(m))
            });
            let Some(i) = ready else {
                return Err(import_cycle(&pending, &imports, &module_files));
            };
            let file = pending.remove(i);
            let added = composer
                .add_composable_module(ComposableModuleDescriptor {
                    source: &sources[file],
                    file_path: file,
                    language: ShaderLanguage::Wgsl,
                    as_name: None,
                    additional_imports: &[],
                    shader_defs: HashMap::new(),
                })
                .map(|_| ());
            if let Err(e) = added {
                return Err(composer_error(&e, &composer, file));
            }
        }
        Ok(Self {
            dir,
            sources,
            module_files,
            imports,
            composer: Arc::new(Mutex::new(composer)),
            composed: HashSet::new(),
        })
    }

    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_deref()
    }

    pub fn source(&self, file: &str) -> Option<&str> {
        self.sources.get(file).map(String::as_str)
    }

    /// The shaders of `dir`; if they do not compose, the embedded ones (still bound to `dir`, so
    /// the next reload reads the folder again) and the error.
    pub fn for_dir(dir: &Path) -> (Self, Option<ShaderError>) {
        match Self::from_dir(dir) {
            Ok(lib) => (lib, None),
            Err(e) => {
                let mut lib = Self::embedded().expect("embedded shaders compose (tested)");
                lib.dir = Some(dir.to_path_buf());
                (lib, Some(e))
            }
        }
    }

    /// A new library read afresh from the folder after `changed` files changed. The whole
    /// folder is read, not only those files: a library is consistent, and a folder is a handful
    /// of small files (what differs from this library is [`Self::changed_files`], whatever the
    /// events named). A changed file of the embedded set that is gone (deleted, or mid-rename) is
    /// an error, not a silent return to the embedded version.
    pub fn reloaded(&self, changed: &[String]) -> Result<Self, ShaderError> {
        let dir =
            self.dir.as_ref().ok_or_else(|| ShaderError::whole_file("shaders", "no shader folder to reload from"))?;
        for file in changed {
            // A file of the folder's own gone (a scratch file, the duplicate an error named) is
            // simply no longer there; what imported it is rebuilt and fails to compose where it
            // uses it. One of the embedded set would be replaced by its embedded version without
            // a word.
            let path = dir.join(file);
            if EMBEDDED.iter().any(|(f, _)| f == file) || path.exists() {
                read_source(&path)?;
            }
        }
        let sources = read_folder(dir)?;
        if self.sources.keys().any(|f| !sources.contains_key(f)) {
            return Self::from_sources(Some(dir.clone()), sources);
        }
        // Only entry files changed: same modules, same composer. Each edited file is scanned
        // once (the scan finds both whether it declares a module and what it imports).
        let edited: Vec<&String> = edited_or_added(&sources, &self.sources).collect();
        let mut imports = self.imports.clone();
        let mut module_edited = false;
        for &f in &edited {
            let source = &sources[f];
            let (module_path, file_imports, _) = get_preprocessor_data(source);
            if module_path.is_some() || self.is_module(f) {
                module_edited = true;
                break;
            }
            imports.insert(f.clone(), file_imports.into_iter().map(|i| i.import).collect());
        }
        if module_edited {
            return Self::from_sources(Some(dir.clone()), sources);
        }
        // Every file's switches, not only the edited ones': a `#define` taken out of an entry
        // file can leave a module testing a name nothing defines. (A save of the same text, the
        // second event of many saves, changed nothing to check.)
        if !edited.is_empty() {
            feature_switches::check(&sources)?;
        }
        Ok(Self {
            dir: Some(dir.clone()),
            sources,
            module_files: self.module_files.clone(),
            imports,
            composer: Arc::clone(&self.composer),
            composed: HashSet::new(),
        })
    }

    /// The files whose source differs between this library and `other` (edited, added or
    /// removed), sorted: what a reload must rebuild for, whichever events announced it.
    pub fn changed_files(&self, other: &Self) -> Vec<String> {
        let mut changed: BTreeSet<&String> = edited_or_added(&self.sources, &other.sources).collect();
        changed.extend(other.sources.keys().filter(|f| !self.sources.contains_key(*f)));
        changed.into_iter().cloned().collect()
    }

    /// Whether `file` is one of the library's entry points (a file no other imports as a
    /// module: forward.wgsl, tonemap.wgsl, …).
    pub fn is_entry(&self, file: &str) -> bool {
        self.sources.contains_key(file) && !self.is_module(file)
    }

    /// Whether `entry` was composed with this library (in any variant).
    pub fn has_composed(&self, entry: &str) -> bool {
        self.composed.contains(entry)
    }

    /// Whether `file` declares a module (`#define_import_path`) in this library.
    fn is_module(&self, file: &str) -> bool {
        self.module_files.values().any(|m| m == file)
    }

    /// Whether `entry` (transitively) includes any of `files`, itself included.
    pub fn depends_on(&self, entry: &str, files: &[String]) -> bool {
        let mut seen = HashSet::new();
        let mut stack = vec![entry.to_owned()];
        while let Some(f) = stack.pop() {
            if files.contains(&f) {
                return true;
            }
            if seen.insert(f.clone()) {
                for m in self.imports.get(&f).into_iter().flatten() {
                    if let Some(dep) = self.module_files.get(m) {
                        stack.push(dep.clone());
                    }
                }
            }
        }
        false
    }

    /// Whether `entry` composed with `defs` reads any of `files`: like [`Self::depends_on`], but
    /// following only the imports naga_oil's preprocessor keeps under those switches and whose
    /// items the code uses (composition parses no other module), so an edit to `ies.wgsl`
    /// reaches only variants with IES lights. Where the preprocessor fails, `true`: composing
    /// will report it.
    pub fn variant_uses(&self, entry: &str, defs: &ShaderDefs, files: &[String]) -> bool {
        if !self.depends_on(entry, files) {
            return false;
        }
        if files.iter().any(|f| f == entry) {
            return true;
        }
        let Some(source) = self.sources.get(entry) else { return true };
        // As `Composer::make_naga_module` does: the entry's own `#define`s join the variant's.
        let mut shader_defs = defs.to_naga_oil();
        match PREPROCESSOR.get_preprocessor_metadata(source, true) {
            Ok(meta) => shader_defs.extend(meta.defines),
            Err(_) => return true,
        }
        // The preprocessor writes each use of an imported item with its module's name encoded
        // after it (naga_oil's decoration); a module whose mark appears is one the variant uses.
        // (It marks uses inside comments too, which can only add a module: a harmless rebuild.)
        let marks: Vec<(String, &str)> =
            self.module_files.iter().map(|(m, f)| (Composer::decorated_name(Some(m), ""), f.as_str())).collect();
        let mut seen = HashSet::new();
        let mut stack = vec![entry];
        while let Some(file) = stack.pop() {
            if files.iter().any(|f| f == file) {
                return true;
            }
            if !seen.insert(file) {
                continue;
            }
            let Some(source) = self.sources.get(file) else { continue };
            let Ok(out) = PREPROCESSOR.preprocess(source, &shader_defs) else { return true };
            stack.extend(marks.iter().filter(|(mark, _)| out.preprocessed_source.contains(mark)).map(|(_, f)| *f));
        }
        false
    }

    /// Composes and validates `file` in its plain variant (no switches): an entry file as
    /// itself; a module as if it were an entry (its own source composed with its imports, so
    /// every function in it is validated, not only those some entry calls), with the values the
    /// entry files `#define` (a module may test those). A reload runs this on each changed file
    /// that no rebuilt pipeline composed, so a mistake shows on save rather than when a scene
    /// first needs the code. (naga_oil parses a module only when a variant imports it.)
    pub fn check_plain(&mut self, file: &str) -> Result<(), ShaderError> {
        if !self.is_module(file) {
            return self.compose(file, &ShaderDefs::default()).map(|_| ());
        }
        let source = self.sources.get(file).ok_or_else(|| ShaderError::whole_file(file, "no such shader"))?;
        let mut shader_defs = HashMap::new();
        for (entry, entry_source) in &self.sources {
            if self.is_entry(entry)
                && let Ok(meta) = PREPROCESSOR.get_preprocessor_metadata(entry_source, true)
            {
                shader_defs.extend(meta.defines);
            }
        }
        let mut composer = self.composer.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        composer
            .make_naga_module(NagaModuleDescriptor {
                source,
                file_path: file,
                shader_type: ShaderType::Wgsl,
                shader_defs,
                additional_imports: &[],
            })
            .map(|_| ())
            .map_err(|e| composer_error(&e, &composer, file))
    }

    /// Composes and validates `entry` with `defs` into a naga module.
    pub fn compose(&mut self, entry: &str, defs: &ShaderDefs) -> Result<naga::Module, ShaderError> {
        let source = self.sources.get(entry).ok_or_else(|| ShaderError::whole_file(entry, "no such shader"))?;
        if source.trim().is_empty() {
            return Err(ShaderError::whole_file(entry, "the file is empty"));
        }
        // A poisoned lock only means a panic elsewhere mid-composition; the modules are intact.
        let mut composer = self.composer.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        let module = composer
            .make_naga_module(NagaModuleDescriptor {
                source,
                file_path: entry,
                shader_type: ShaderType::Wgsl,
                shader_defs: defs.to_naga_oil(),
                additional_imports: &[],
            })
            .map_err(|e| composer_error(&e, &composer, entry))?;
        drop(composer);
        if !self.composed.contains(entry) {
            self.composed.insert(entry.to_owned());
        }
        Ok(module)
    }

    /// Composes `entry` and creates the GPU module, catching validation errors wgpu would
    /// otherwise raise as an uncaptured error.
    pub fn create_module(
        &mut self,
        device: &wgpu::Device,
        entry: &str,
        defs: &ShaderDefs,
    ) -> Result<wgpu::ShaderModule, ShaderError> {
        let start = std::time::Instant::now();
        let module = self.compose(entry, defs)?;
        let composed = start.elapsed();
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let label = format!("{entry} {defs}");
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(&label),
            source: wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(module)),
        });
        tracing::debug!(
            "{label}: composed and validated in {:.1} ms, shader module created in {:.1} ms",
            composed.as_secs_f64() * 1e3,
            (start.elapsed() - composed).as_secs_f64() * 1e3
        );
        match pollster::block_on(scope.pop()) {
            None => Ok(shader),
            Some(e) => Err(ShaderError::from_wgpu(entry, &e)),
        }
    }
}

/// The files of `now` whose source `before` does not hold (edited or added), in name order.
fn edited_or_added<'a>(
    now: &'a BTreeMap<String, String>,
    before: &BTreeMap<String, String>,
) -> impl Iterator<Item = &'a String> {
    now.iter().filter(|(f, s)| before.get(*f) != Some(*s)).map(|(f, _)| f)
}

/// The error for modules that import each other in a ring, at a file on the ring (not merely one
/// importing into it): `pending` are the modules none of whose imports could be registered.
fn import_cycle(
    pending: &[&String],
    imports: &HashMap<String, Vec<String>>,
    module_files: &HashMap<String, String>,
) -> ShaderError {
    // Every pending module imports another pending one, so following any such import from any of
    // them must come back to a file already on the path.
    let next =
        |file: &String| imports[file].iter().filter_map(|m| module_files.get(m)).find(|f| pending.contains(f)).cloned();
    let mut path: Vec<String> = vec![pending[0].clone()];
    while let Some(to) = next(path.last().expect("never empty")) {
        if let Some(start) = path.iter().position(|f| *f == to) {
            let ring: Vec<&str> = path[start..].iter().chain([&to]).map(String::as_str).collect();
            return ShaderError::whole_file(&to, format!("import cycle between shader modules: {}", ring.join(" → ")));
        }
        path.push(to);
    }
    ShaderError::whole_file(pending[0], "import cycle between shader modules")
}

/// Every `*.wgsl` in `dir` by file name, over the embedded set (which fills in what `dir` lacks).
fn read_folder(dir: &Path) -> Result<BTreeMap<String, String>, ShaderError> {
    let mut sources: BTreeMap<String, String> = EMBEDDED.iter().map(|(f, s)| (f.to_string(), s.to_string())).collect();
    let entries = std::fs::read_dir(dir)
        .map_err(|e| ShaderError::whole_file(&dir.display().to_string(), format!("cannot read the folder: {e}")))?;
    for entry in entries.flatten() {
        let path = entry.path();
        if let Some(name) = shader_file_name(&path) {
            sources.insert(name.to_owned(), read_source(&path)?);
        }
    }
    Ok(sources)
}

/// The file name of a shader in a watched folder: `*.wgsl`, not hidden. Editors keep hidden
/// files beside the one being edited (Emacs's lock `.#forward.wgsl`, a dangling link while a
/// buffer has unsaved changes), which are not shaders and must not fail a reload.
pub(crate) fn shader_file_name(path: &Path) -> Option<&str> {
    let name = path.file_name()?.to_str()?;
    (path.extension().and_then(|e| e.to_str()) == Some("wgsl") && !name.starts_with('.')).then_some(name)
}

/// Reads a shader file. An empty file (editors often truncate before writing) or a missing one
/// (deleted, or mid-rename) is an error like any other, reported until the file is whole again.
fn read_source(path: &Path) -> Result<String, ShaderError> {
    let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
    let source =
        std::fs::read_to_string(path).map_err(|e| ShaderError::whole_file(&name, format!("cannot read: {e}")))?;
    if source.trim().is_empty() {
        return Err(ShaderError::whole_file(&name, "the file is empty"));
    }
    Ok(source)
}

/// The size and member offsets of the struct `name` as WGSL lays it out in the embedded `entry`
/// composed with `defs` (an imported struct's name gets a module suffix in composition). For
/// tests that hold a Rust mirror of a GPU struct to its WGSL layout: [`assert_mirrors_wgsl`].
#[cfg(test)]
pub(crate) fn wgsl_struct_layout(entry: &str, defs: &[&'static str], name: &str) -> (u32, Vec<(String, u32)>) {
    let defs = ShaderDefs(defs.iter().copied().collect());
    let module = ShaderLibrary::embedded().unwrap().compose(entry, &defs).unwrap_or_else(|e| panic!("{e}"));
    let named = |n: &str| n == name || n.strip_prefix(name).is_some_and(|rest| rest.starts_with("X_naga_oil"));
    module
        .types
        .iter()
        .find_map(|(_, ty)| match (&ty.name, &ty.inner) {
            (Some(n), naga::TypeInner::Struct { members, span }) if named(n) => {
                Some((*span, members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect()))
            }
            _ => None,
        })
        .unwrap_or_else(|| panic!("no struct {name} in {entry} composed with {defs}"))
}

/// Asserts that a `#[repr(C)]` Rust struct has the size of its WGSL counterpart and each listed
/// field the offset of the WGSL member named the same (or named by a string after `=>`):
/// `assert_mirrors_wgsl!(GpuLight, "forward.wgsl", [], "Light", [position, kind])`; the defs are
/// any array or slice of `&'static str` (a const shared by several structs' checks).
#[cfg(test)]
macro_rules! assert_mirrors_wgsl {
    ($ty:ty, $entry:expr, $defs:expr, $name:expr, [$($field:ident $(=> $member:expr)?),* $(,)?]) => {{
        let (size, members) = $crate::pipelines::shader_library::wgsl_struct_layout($entry, &$defs, $name);
        assert_eq!(std::mem::size_of::<$ty>(), size as usize, "size of {} against WGSL {}", stringify!($ty), $name);
        $(
            let member = [$($member,)? stringify!($field)][0];
            let offset = members.iter().find(|(n, _)| n == member).map(|(_, o)| *o as usize);
            assert_eq!(
                Some(std::mem::offset_of!($ty, $field)),
                offset,
                "{}::{} against {}.{}",
                stringify!($ty),
                stringify!($field),
                $name,
                member
            );
        )*
    }};
}
#[cfg(test)]
pub(crate) use assert_mirrors_wgsl;

#[cfg(test)]
mod tests;
