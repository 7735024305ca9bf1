//! The pipeline cache: every pipeline of every family, each compiled once per key and kept
//! until a shader it reads changes. It knows no family by name.
//!
//! A family ([`PipelineFamily`]) is a type its feature defines beside the pass that uses it:
//! its key, the entry file and `#ifdef` switches a key composes (so a scene without normal maps
//! or local lights runs shaders without them), and how a pipeline is made from the composed
//! module (the family holds its own bind group and pipeline layouts). A feature registers its
//! families when it is made ([`PipelineCache::register`]); from then on:
//!
//! 1. [`PipelineCache::prepare`] compiles the keys a frame needs that are not compiled yet. Each
//!    variant (entry file and switches) is composed once, however many keys share it (keys that
//!    differ only in raster state), and the pipelines are created on up to one thread per core:
//!    a driver that compiles at creation would otherwise make a frame wait for the sum.
//! 2. [`PipelineCache::cached`] hands a compiled pipeline to the pass that records it.
//! 3. Hot reload ([`PipelineCache::reload`]) builds a candidate shader library from the changed
//!    files, walks every registered family, rebuilds each cached pipeline whose variant reads a
//!    changed file with the candidate, inside a wgpu error scope, and only if all succeed swaps
//!    the library and those pipelines in. Pipelines that do not read the changed files are
//!    untouched. On any error nothing changes and frames keep drawing with the last good
//!    pipelines.

use std::any::{Any, TypeId};
use std::collections::HashMap;
use std::hash::Hash;

use super::shader_library::{ShaderDefs, ShaderError, ShaderLibrary};
use super::store::PipelineStore;

/// What a family creates its pipelines with: the device, and the driver's pipeline cache where
/// the run keeps one ([`PipelineStore`]), which every pipeline descriptor names so that a later
/// run finds what this one compiled. Dereferences to the device.
#[derive(Clone, Copy)]
pub struct Compiler<'a> {
    device: &'a wgpu::Device,
    cache: Option<&'a wgpu::PipelineCache>,
}

impl<'a> Compiler<'a> {
    pub fn new(device: &'a wgpu::Device, cache: Option<&'a wgpu::PipelineCache>) -> Self {
        Self { device, cache }
    }

    /// The value of a pipeline descriptor's `cache`.
    pub fn cache(&self) -> Option<&'a wgpu::PipelineCache> {
        self.cache
    }
}

impl std::ops::Deref for Compiler<'_> {
    type Target = wgpu::Device;

    fn deref(&self) -> &wgpu::Device {
        self.device
    }
}

/// One kind of pipeline, compiled per key: a feature's pass (or one step of it).
pub trait PipelineFamily: Send + Sync + 'static {
    /// Everything that selects one pipeline of the family.
    type Key: Copy + Eq + Hash + std::fmt::Debug + Send + Sync + 'static;
    /// `wgpu::RenderPipeline` or `wgpu::ComputePipeline`.
    type Pipeline: Send + Sync + 'static;
    /// The family's name in reload reports.
    const NAME: &'static str;
    /// Whether the entry file imports modules under `#ifdef` switches, so that an edited module
    /// reaches only some variants (checked per variant with `ShaderLibrary::variant_uses`).
    /// Otherwise every variant reads what its entry file imports.
    const PER_VARIANT: bool = false;

    /// The entry file and switches `key`'s module is composed from.
    fn shader(&self, key: &Self::Key) -> (&'static str, ShaderDefs);

    /// The pipeline of `key` from its composed module. Runs inside a validation error scope: a
    /// shader that composes but does not fit the pipeline is an error, not a crash.
    fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, key: &Self::Key) -> Self::Pipeline;
}

/// What a hot reload did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReloadReport {
    /// The files that differ from the library replaced (sorted), whichever events announced them.
    pub files: Vec<String>,
    /// Pipelines rebuilt because they read a changed file.
    pub rebuilt: usize,
    /// Those pipelines by family (`forward`, `tonemap`, `environment`, …) in registration
    /// order, families with none left out.
    pub families: Vec<(&'static str, usize)>,
    /// Pipelines left alone.
    pub untouched: usize,
}

impl ReloadReport {
    /// How many pipelines of family `F` the reload rebuilt.
    pub fn rebuilt_of<F: PipelineFamily>(&self) -> usize {
        self.families.iter().find(|(name, _)| *name == F::NAME).map_or(0, |(_, n)| *n)
    }
}

/// A family and its compiled pipelines.
struct Slot<F: PipelineFamily> {
    family: F,
    pipelines: HashMap<F::Key, F::Pipeline>,
}

/// A slot with its family's types erased, so the cache (and its reload) can hold any number.
trait AnySlot: Any + Send + Sync {
    fn name(&self) -> &'static str;
    fn len(&self) -> usize;
    /// The keys whose variant reads a file `reach` holds changed.
    fn stale(&self, reach: &Reach) -> Box<dyn Any + Send>;
    /// Rebuilds the `stale` keys' pipelines with `library`; returns how many and the new
    /// pipelines, for [`AnySlot::commit`].
    fn rebuild(
        &self,
        device: &Compiler,
        library: &mut ShaderLibrary,
        stale: Box<dyn Any + Send>,
    ) -> Result<(usize, Box<dyn Any + Send>), ShaderError>;
    fn commit(&mut self, staged: Box<dyn Any + Send>);
}

impl<F: PipelineFamily> AnySlot for Slot<F> {
    fn name(&self) -> &'static str {
        F::NAME
    }

    fn len(&self) -> usize {
        self.pipelines.len()
    }

    fn stale(&self, reach: &Reach) -> Box<dyn Any + Send> {
        let stale: Vec<F::Key> = self
            .pipelines
            .keys()
            .filter(|key| {
                let (entry, defs) = self.family.shader(key);
                if F::PER_VARIANT { reach.variant(entry, &defs) } else { reach.entry(entry) }
            })
            .copied()
            .collect();
        Box::new(stale)
    }

    fn rebuild(
        &self,
        device: &Compiler,
        library: &mut ShaderLibrary,
        stale: Box<dyn Any + Send>,
    ) -> Result<(usize, Box<dyn Any + Send>), ShaderError> {
        let stale = stale.downcast::<Vec<F::Key>>().expect("listed by this slot's stale");
        // The first error fails the whole reload, which then swaps in nothing.
        let built = build(&self.family, device, library, &stale)
            .into_iter()
            .map(|(key, pipeline)| pipeline.map(|p| (key, p)))
            .collect::<Result<Vec<_>, _>>()?;
        Ok((built.len(), Box::new(built)))
    }

    fn commit(&mut self, staged: Box<dyn Any + Send>) {
        let built = staged.downcast::<Vec<(F::Key, F::Pipeline)>>().expect("staged by this slot's rebuild");
        self.pipelines.extend(*built);
    }
}

/// Builds the pipelines of `keys`, each with its own outcome, in `keys`' order.
fn build<F: PipelineFamily>(
    family: &F,
    device: &Compiler,
    library: &mut ShaderLibrary,
    keys: &[F::Key],
) -> Vec<(F::Key, Result<F::Pipeline, ShaderError>)> {
    let shaders: Vec<(&'static str, ShaderDefs)> = keys.iter().map(|k| family.shader(k)).collect();
    let mut modules: HashMap<&(&'static str, ShaderDefs), Result<wgpu::ShaderModule, ShaderError>> = HashMap::new();
    for shader in &shaders {
        if !modules.contains_key(shader) {
            let module = library.create_module(device, shader.0, &shader.1);
            modules.insert(shader, module);
        }
    }
    let create = |i: usize| {
        let (file, _) = &shaders[i];
        let module = modules[&shaders[i]].as_ref().map_err(Clone::clone)?;
        let start = std::time::Instant::now();
        let pipeline = checked(device, file, || family.create(device, module, &keys[i]));
        tracing::debug!("{} pipeline created in {:.1} ms", F::NAME, start.elapsed().as_secs_f64() * 1e3);
        pipeline
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(keys.len());
    let mut built: Vec<(usize, Result<F::Pipeline, ShaderError>)> = if threads <= 1 {
        (0..keys.len()).map(|i| (i, create(i))).collect()
    } else {
        let next = std::sync::atomic::AtomicUsize::new(0);
        std::thread::scope(|scope| {
            let workers: Vec<_> = (0..threads)
                .map(|_| {
                    scope.spawn(|| {
                        let mut mine = Vec::new();
                        loop {
                            let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                            if i >= keys.len() {
                                break mine;
                            }
                            mine.push((i, create(i)));
                        }
                    })
                })
                .collect();
            workers
                .into_iter()
                .flat_map(|w| w.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)))
                .collect()
        })
    };
    built.sort_by_key(|(i, _)| *i);
    built.into_iter().map(|(i, pipeline)| (keys[i], pipeline)).collect()
}

/// Runs `create` inside a validation error scope, so a shader that composes but does not fit
/// its pipeline (a renamed entry point, a changed binding) is an error, not a crash.
fn checked<P>(device: &wgpu::Device, file: &str, create: impl FnOnce() -> P) -> Result<P, ShaderError> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let pipeline = create();
    match pollster::block_on(scope.pop()) {
        None => Ok(pipeline),
        Some(e) => Err(ShaderError::from_wgpu(file, &e)),
    }
}

/// Which pipelines a reload's changed files reach. A file removed from the folder is traced in
/// the library it was removed from, whose imports still know who read it: that importer is
/// rebuilt, and fails to compose where it uses the file instead of running on with the deleted
/// code.
struct Reach<'a> {
    new: &'a ShaderLibrary,
    old: &'a ShaderLibrary,
    files: &'a [String],
    removed: Vec<String>,
}

impl<'a> Reach<'a> {
    fn new(new: &'a ShaderLibrary, old: &'a ShaderLibrary, files: &'a [String]) -> Self {
        let removed = files.iter().filter(|f| new.source(f).is_none()).cloned().collect();
        Self { new, old, files, removed }
    }

    /// Whether any variant of `entry` may read a changed file.
    fn entry(&self, entry: &str) -> bool {
        self.new.depends_on(entry, self.files) || self.old.depends_on(entry, &self.removed)
    }

    /// Whether the variant of `entry` with `defs` reads a changed file.
    fn variant(&self, entry: &str, defs: &ShaderDefs) -> bool {
        self.new.variant_uses(entry, defs, self.files) || self.old.variant_uses(entry, defs, &self.removed)
    }
}

/// Every registered family's pipelines, and the shader library they were compiled from.
pub struct PipelineCache {
    shaders: ShaderLibrary,
    /// The driver's cache kept between runs, where there is one; every pipeline names it.
    store: Option<PipelineStore>,
    /// In registration order (the order of reload reports).
    slots: Vec<Box<dyn AnySlot>>,
    index: HashMap<TypeId, usize>,
    /// Pipelines created since start-up (a pipeline compiled twice would show here).
    pub compiled: usize,
    /// Incremented by every successful reload.
    pub generation: u64,
}

impl PipelineCache {
    pub fn new(shaders: ShaderLibrary) -> Self {
        Self { shaders, store: None, slots: Vec::new(), index: HashMap::new(), compiled: 0, generation: 0 }
    }

    /// Creates every pipeline from now on with `store`'s driver cache.
    pub fn set_store(&mut self, store: Option<PipelineStore>) {
        self.store = store;
    }

    pub fn store(&self) -> Option<&PipelineStore> {
        self.store.as_ref()
    }

    pub fn shaders(&self) -> &ShaderLibrary {
        &self.shaders
    }

    /// Adds a family; a family registered before is kept as it is.
    pub fn register<F: PipelineFamily>(&mut self, family: F) {
        if let std::collections::hash_map::Entry::Vacant(e) = self.index.entry(TypeId::of::<F>()) {
            e.insert(self.slots.len());
            self.slots.push(Box::new(Slot { family, pipelines: HashMap::<F::Key, F::Pipeline>::new() }));
        }
    }

    fn slot<F: PipelineFamily>(&self) -> &Slot<F> {
        let i = self.index.get(&TypeId::of::<F>()).unwrap_or_else(|| panic!("{} is not registered", F::NAME));
        let slot: &dyn Any = self.slots[*i].as_ref();
        slot.downcast_ref().expect("indexed by its type")
    }

    /// The family itself: its bind group layouts, for the feature that binds its resources.
    pub fn family<F: PipelineFamily>(&self) -> &F {
        &self.slot::<F>().family
    }

    /// Compiles the pipelines of `keys` not compiled yet. Each is tried (a variant that fails
    /// leaves the others usable); the first error, in `keys`' order, is returned.
    pub fn prepare<F: PipelineFamily>(
        &mut self,
        device: &wgpu::Device,
        keys: impl IntoIterator<Item = F::Key>,
    ) -> Result<(), ShaderError> {
        let slot = self.slot::<F>();
        let mut missing: Vec<F::Key> = Vec::new();
        for key in keys {
            if !slot.pipelines.contains_key(&key) && !missing.contains(&key) {
                missing.push(key);
            }
        }
        if missing.is_empty() {
            return Ok(());
        }
        self.compiled += missing.len();
        let i = self.index[&TypeId::of::<F>()];
        let slot: &mut dyn Any = self.slots[i].as_mut();
        let slot: &mut Slot<F> = slot.downcast_mut().expect("indexed by its type");
        let mut first_error = None;
        let compiler = Compiler::new(device, self.store.as_ref().map(PipelineStore::cache));
        for (key, pipeline) in build(&slot.family, &compiler, &mut self.shaders, &missing) {
            match pipeline {
                Ok(p) => {
                    slot.pipelines.insert(key, p);
                }
                Err(e) => first_error = first_error.or(Some(e)),
            }
        }
        first_error.map_or(Ok(()), Err)
    }

    /// The pipeline of `key`, compiling it on first use.
    pub fn get<F: PipelineFamily>(&mut self, device: &wgpu::Device, key: F::Key) -> Result<&F::Pipeline, ShaderError> {
        self.prepare::<F>(device, [key])?;
        Ok(&self.slot::<F>().pipelines[&key])
    }

    /// A pipeline compiled before ([`PipelineCache::prepare`]), `None` if it is not (it failed).
    pub fn cached<F: PipelineFamily>(&self, key: &F::Key) -> Option<&F::Pipeline> {
        self.slot::<F>().pipelines.get(key)
    }

    /// Every compiled pipeline of family `F`, by key: for a pass that looks up many keys (one
    /// lookup of the family instead of one per key).
    pub fn compiled<F: PipelineFamily>(&self) -> &HashMap<F::Key, F::Pipeline> {
        &self.slot::<F>().pipelines
    }

    /// The keys of family `F` compiled so far.
    pub fn keys<F: PipelineFamily>(&self) -> Vec<F::Key> {
        self.slot::<F>().pipelines.keys().copied().collect()
    }

    /// How many pipelines of family `F` are compiled.
    pub fn count<F: PipelineFamily>(&self) -> usize {
        self.slot::<F>().pipelines.len()
    }

    /// Every pipeline compiled so far.
    fn pipeline_count(&self) -> usize {
        self.slots.iter().map(|s| s.len()).sum()
    }

    /// Re-reads the shader folder after `files` changed and rebuilds the pipelines that read what
    /// changed; on any error keeps everything as it was and returns the error. What changed is
    /// what differs between the folder and the library in use, not only `files`: an event can
    /// arrive after the reload that read its file (a save of several files), and a library that
    /// fell back to the embedded shaders differs from the folder in every file the folder edits.
    pub fn reload(&mut self, device: &wgpu::Device, files: &[String]) -> Result<ReloadReport, ShaderError> {
        let start = std::time::Instant::now();
        let mut candidate = self.shaders.reloaded(files)?;
        tracing::debug!("candidate shader library built in {:.1} ms", start.elapsed().as_secs_f64() * 1e3);
        let changed = candidate.changed_files(&self.shaders);
        let total = self.pipeline_count();
        if changed.is_empty() {
            // An event that changed nothing (a save of the same text, a restored file, a second
            // event of one save): the pipelines in use were compiled from exactly these sources.
            return Ok(ReloadReport { files: changed, rebuilt: 0, families: Vec::new(), untouched: total });
        }
        // Which keys are stale is read from the candidate before anything composes with it.
        let reach = Reach::new(&candidate, &self.shaders, &changed);
        let stale: Vec<_> = self.slots.iter().map(|slot| slot.stale(&reach)).collect();
        let mut staged = Vec::with_capacity(self.slots.len());
        let compiler = Compiler::new(device, self.store.as_ref().map(PipelineStore::cache));
        for (slot, keys) in self.slots.iter().zip(stale) {
            staged.push(slot.rebuild(&compiler, &mut candidate, keys)?);
        }
        // A changed file that no rebuilt pipeline composed (a pass this scene does not run, a
        // module only other variants import) is composed and validated in its plain variant all
        // the same, so a mistake shows now rather than when a scene first needs it. Nothing to do
        // for an edited entry whose pipelines were rebuilt (the reload benchmark's).
        let unchecked: Vec<String> = changed
            .iter()
            .filter(|f| candidate.source(f).is_some() && !(candidate.is_entry(f) && candidate.has_composed(f)))
            .cloned()
            .collect();
        for file in unchecked {
            candidate.check_plain(&file)?;
        }
        self.shaders = candidate;
        let mut families = Vec::new();
        for (slot, (count, pipelines)) in self.slots.iter_mut().zip(staged) {
            slot.commit(pipelines);
            if count > 0 {
                families.push((slot.name(), count));
            }
        }
        let rebuilt = families.iter().map(|(_, n)| n).sum::<usize>();
        self.compiled += rebuilt;
        self.generation += 1;
        Ok(ReloadReport { files: changed, rebuilt, families, untouched: total - rebuilt })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipelines::parts::{self, texture, uniform};

    /// A stand-in family: `mipmap.wgsl`'s pipelines by output format and sRGB switch.
    struct Stand {
        layout: wgpu::PipelineLayout,
    }

    impl PipelineFamily for Stand {
        type Key = (wgpu::TextureFormat, bool);
        type Pipeline = wgpu::RenderPipeline;
        const NAME: &'static str = "stand-in";

        fn shader(&self, &(_, srgb): &Self::Key) -> (&'static str, ShaderDefs) {
            ("mipmap.wgsl", ShaderDefs::default().with("SRGB", srgb))
        }

        fn create(&self, device: &Compiler, module: &wgpu::ShaderModule, &(format, _): &Self::Key) -> Self::Pipeline {
            parts::fullscreen_pipeline(device, &self.layout, module, format, "stand-in")
        }
    }

    fn stand(device: &wgpu::Device) -> Stand {
        let group = parts::bind_group_layout(
            device,
            "stand-in",
            &[texture(0, false), uniform(1, wgpu::ShaderStages::FRAGMENT)],
        );
        Stand { layout: parts::pipeline_layout(device, "stand-in", &[&group]) }
    }

    #[test]
    fn a_registered_family_compiles_each_key_once_and_reloads_what_reads_a_changed_file() {
        let ctx = crate::GpuContext::new_headless(&crate::AdapterRequest::default()).expect(crate::INSTALL_HINT);
        let dir = std::env::temp_dir().join(format!("penumbra-cache-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let mut cache = PipelineCache::new(ShaderLibrary::from_dir(&dir).unwrap());
        cache.register(stand(&ctx.device));
        let (unorm, float) = (wgpu::TextureFormat::Rgba8Unorm, wgpu::TextureFormat::Rgba16Float);
        let keys = [(unorm, false), (float, false), (unorm, true), (unorm, false)];
        cache.prepare::<Stand>(&ctx.device, keys).unwrap();
        assert_eq!((cache.count::<Stand>(), cache.compiled), (3, 3), "a repeated key is compiled once");
        assert!(cache.cached::<Stand>(&(float, false)).is_some() && cache.cached::<Stand>(&(float, true)).is_none());
        cache.prepare::<Stand>(&ctx.device, keys).unwrap();
        assert_eq!(cache.compiled, 3, "compiled keys are not compiled again");

        let edit = |file: &str, text: &str| {
            let source = crate::pipelines::shader_library::EMBEDDED.iter().find(|(f, _)| *f == file).unwrap().1;
            std::fs::write(dir.join(file), format!("{source}\n{text}\n")).unwrap();
        };
        // An entry no pipeline of the family reads: nothing rebuilt, the file still checked.
        edit("bloom.wgsl", "// edited");
        let report = cache.reload(&ctx.device, &["bloom.wgsl".to_owned()]).unwrap();
        assert_eq!((report.rebuilt, report.untouched, report.families.len()), (0, 3, 0), "{report:?}");
        // A module the entry imports: every pipeline of the family is rebuilt.
        edit("display.wgsl", "// edited");
        let report = cache.reload(&ctx.device, &["display.wgsl".to_owned()]).unwrap();
        assert_eq!(report.families, [("stand-in", 3)]);
        assert_eq!((report.rebuilt_of::<Stand>(), report.untouched, cache.generation), (3, 0, 2));
        // A broken entry: the reload fails and swaps nothing in.
        edit("mipmap.wgsl", "fn broken( {");
        let error = cache.reload(&ctx.device, &["mipmap.wgsl".to_owned()]).unwrap_err();
        assert_eq!(error.file, "mipmap.wgsl", "{error}");
        assert_eq!((cache.count::<Stand>(), cache.generation), (3, 2), "the last good pipelines stay");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
