//! The scene's environment: the light arriving from infinitely far away in every direction
//! (image-based lighting), and what is drawn behind the scene.
//!
//! [`Environment`] is a resource of the main world. Its source is a procedural sky lit by the
//! scene's sun, a neutral studio gradient, or an equirectangular HDR image
//! ([`EnvironmentImage`], from a Radiance `.hdr` or OpenEXR file, or written by code). The render
//! crate's extraction copies it when it changes; the renderer prefilters it on the GPU (only
//! then) into the maps the shaders read. Without the resource a scene has no image-based light
//! and pays nothing for it.
//!
//! Units: image texels and the studio gradient are radiance in cd/m² (nits) before
//! [`Environment::intensity`]; the sky's radiance follows its sun's illuminance in lux (see
//! [`Sky`]).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use bevy_ecs::resource::Resource;
use glam::Vec3;

/// The scene's environment light and background. Insert it as a resource to light the scene
/// with it.
#[derive(Resource, Debug, Clone, PartialEq)]
pub struct Environment {
    pub source: EnvironmentSource,
    /// Multiplies the source's radiance (light and background alike). Finite and ≥ 0.
    pub intensity: f32,
    /// Turns the environment about +Y, radians (counter-clockwise seen from above).
    pub rotation: f32,
    /// What the frame shows where no surface is.
    pub background: Background,
}

impl Default for Environment {
    fn default() -> Self {
        Self { source: EnvironmentSource::Auto, intensity: 1.0, rotation: 0.0, background: Background::Environment }
    }
}

impl Environment {
    /// An environment of one image, shown as the background.
    pub fn image(image: Arc<EnvironmentImage>) -> Self {
        Self { source: EnvironmentSource::Image(image), ..Default::default() }
    }

    /// Checks the numbers a user may set; the renderer refuses an environment that fails.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.intensity.is_finite() && self.intensity >= 0.0) {
            return Err(format!("environment intensity {} must be finite and at least 0", self.intensity));
        }
        if !self.rotation.is_finite() {
            return Err(format!("environment rotation {} must be finite", self.rotation));
        }
        if let Background::Color(c) = self.background
            && !c.iter().all(|v| v.is_finite() && *v >= 0.0)
        {
            return Err(format!("background colour {c:?} must be finite and at least 0"));
        }
        if let Background::Blurred(r) = self.background
            && !(0.0..=1.0).contains(&r)
        {
            return Err(format!("background blur {r} must lie in 0..=1 (a perceptual roughness)"));
        }
        match &self.source {
            EnvironmentSource::Sky(sky) => sky.validate()?,
            EnvironmentSource::Image(img) => img.validate()?,
            _ => {}
        }
        Ok(())
    }
}

/// Images compare by identity (the same `Arc`), not texel by texel: comparing sources every
/// frame must not walk millions of texels.
#[derive(Debug, Clone)]
pub enum EnvironmentSource {
    /// The sky of the brightest directional light (the sun) when the scene has one, else the
    /// studio gradient.
    Auto,
    /// A clear sky (Preetham et al. 1999) lit by the brightest directional light; the studio
    /// gradient when there is none.
    Sky(Sky),
    /// A neutral grey gradient: bright above, darker below, no colour cast.
    Studio,
    /// An equirectangular image.
    Image(Arc<EnvironmentImage>),
}

impl PartialEq for EnvironmentSource {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (EnvironmentSource::Auto, EnvironmentSource::Auto) => true,
            (EnvironmentSource::Sky(a), EnvironmentSource::Sky(b)) => a == b,
            (EnvironmentSource::Studio, EnvironmentSource::Studio) => true,
            (EnvironmentSource::Image(a), EnvironmentSource::Image(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

/// Parameters of the procedural sky. Its radiance is Preetham's clear-sky luminance for the
/// sun's elevation, scaled by the sun's illuminance over 100 000 lux (a clear day's sun), so a
/// scene lit by a 3 lux sun gets the sky that sun would have. The sun's disk is not in it: the
/// directional light already carries the sun's light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sky {
    /// Haziness, 2 (very clear) to 10 (hazy).
    pub turbidity: f32,
    /// Reflectance of the ground below the horizon, 0..=1.
    pub ground_albedo: f32,
}

impl Default for Sky {
    fn default() -> Self {
        Self { turbidity: 2.5, ground_albedo: 0.3 }
    }
}

impl Sky {
    pub fn validate(&self) -> Result<(), String> {
        if !(2.0..=10.0).contains(&self.turbidity) {
            return Err(format!("sky turbidity {} must lie in 2..=10", self.turbidity));
        }
        if !(0.0..=1.0).contains(&self.ground_albedo) {
            return Err(format!("sky ground albedo {} must lie in 0..=1", self.ground_albedo));
        }
        Ok(())
    }
}

/// What the frame shows behind the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Background {
    /// The environment itself.
    Environment,
    /// The environment as a surface of this perceptual roughness would reflect it (0..=1).
    Blurred(f32),
    /// Linear radiance in cd/m² (exposed like the scene).
    Color([f32; 3]),
}

/// An equirectangular (latitude-longitude) radiance map: `u` runs with longitude, starting at
/// −Z and turning towards +X (as three.js, Filament and the Khronos viewer read such maps),
/// `v` from straight up (+Y, top row) to straight down.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentImage {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance per texel, rows top to bottom.
    pub texels: Vec<[f32; 3]>,
    /// Where it came from, for messages.
    pub label: String,
}

/// Images larger than this on either side are refused before they are decoded (an 8k × 4k
/// map, the largest common size, is 512 MiB of f32 texels).
pub const MAX_ENVIRONMENT_SIDE: u32 = 8192;

#[derive(Debug, thiserror::Error)]
#[error("environment map {}: {problem}", path.display())]
pub struct EnvironmentError {
    pub path: PathBuf,
    pub problem: String,
}

impl EnvironmentImage {
    /// An image whose texel at each direction is `radiance(direction)` (unit vectors, world
    /// axes): how tests write synthetic environments.
    pub fn from_fn(width: u32, height: u32, label: &str, radiance: impl Fn(Vec3) -> Vec3) -> Self {
        let mut texels = Vec::with_capacity((width * height) as usize);
        for y in 0..height {
            for x in 0..width {
                let u = (x as f32 + 0.5) / width as f32;
                let v = (y as f32 + 0.5) / height as f32;
                texels.push(radiance(direction_of(u, v)).to_array());
            }
        }
        Self { width, height, texels, label: label.into() }
    }

    /// Decodes a Radiance `.hdr` or OpenEXR file (any format the image crate reads, by
    /// content). Errors name the file and the problem; non-finite or negative texels become 0
    /// with a warning (a NaN would poison every prefiltered texel it touches).
    pub fn load(path: &Path) -> Result<Self, EnvironmentError> {
        let err = |problem: String| EnvironmentError { path: path.to_path_buf(), problem };
        let reader = image::ImageReader::open(path)
            .map_err(|e| err(format!("cannot open: {e}")))?
            .with_guessed_format()
            .map_err(|e| err(format!("cannot read: {e}")))?;
        Self::decode(reader, path.display().to_string()).map_err(err)
    }

    /// Like [`EnvironmentImage::load`], from bytes in memory.
    pub fn from_bytes(bytes: &[u8], label: &str) -> Result<Self, EnvironmentError> {
        let err = |problem: String| EnvironmentError { path: PathBuf::from(label), problem };
        let reader = image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| err(format!("cannot read: {e}")))?;
        Self::decode(reader, label.to_string()).map_err(err)
    }

    fn decode<R: std::io::BufRead + std::io::Seek>(
        mut reader: image::ImageReader<R>,
        label: String,
    ) -> Result<Self, String> {
        match reader.format() {
            Some(image::ImageFormat::Hdr | image::ImageFormat::OpenExr) => {}
            Some(f) => {
                return Err(format!(
                    "{f:?} is not a high-dynamic-range format (use a Radiance .hdr or an OpenEXR file)"
                ));
            }
            None => return Err("unknown image format (use a Radiance .hdr or an OpenEXR file)".into()),
        }
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(MAX_ENVIRONMENT_SIDE);
        limits.max_image_height = Some(MAX_ENVIRONMENT_SIDE);
        // RGBA f32 of the largest allowed image, plus the decoder's own buffer.
        limits.max_alloc = Some(2 * 16 * MAX_ENVIRONMENT_SIDE as u64 * MAX_ENVIRONMENT_SIDE as u64 / 2);
        reader.limits(limits);
        let decoded = reader.decode().map_err(|e| match e {
            image::ImageError::Limits(l) => format!(
                "{l} (environment maps may be at most {MAX_ENVIRONMENT_SIDE} texels on a side; \
                 MAX_ENVIRONMENT_SIDE in crates/engine/src/environment.rs)"
            ),
            e => format!("cannot decode: {e}"),
        })?;
        let rgb = decoded.into_rgb32f();
        let (width, height) = rgb.dimensions();
        if width < 2 || height < 1 {
            return Err(format!("{width}×{height} is too small for an environment map"));
        }
        let mut bad = 0usize;
        let texels = rgb
            .pixels()
            .map(|p| {
                p.0.map(|c| {
                    if c.is_finite() && c >= 0.0 {
                        c
                    } else {
                        bad += 1;
                        0.0
                    }
                })
            })
            .collect();
        if bad > 0 {
            tracing::warn!("environment map {label}: {bad} NaN, infinite or negative values replaced by 0");
        }
        Ok(Self { width, height, texels, label })
    }

    /// Checks what code may have built by hand: a size of at least 2 × 1, at most
    /// [`MAX_ENVIRONMENT_SIDE`] a side, and one texel for each.
    pub fn validate(&self) -> Result<(), String> {
        let (w, h) = (self.width, self.height);
        if w < 2 || h < 1 || w > MAX_ENVIRONMENT_SIDE || h > MAX_ENVIRONMENT_SIDE {
            return Err(format!(
                "environment map {}: {w}×{h} is outside 2×1 ..= {MAX_ENVIRONMENT_SIDE}×{MAX_ENVIRONMENT_SIDE}",
                self.label
            ));
        }
        if self.texels.len() != w as usize * h as usize {
            return Err(format!("environment map {}: {} texels for {w}×{h}", self.label, self.texels.len()));
        }
        Ok(())
    }

    /// Halves the image (box filter, area-weighted for odd sizes) until it is at most
    /// `max_width` wide: the mean radiance, and with it the light
    /// a small bright source gives, is kept exactly, where point-sampling a large map would miss
    /// or over-count it.
    pub fn reduced(&self, max_width: u32) -> std::borrow::Cow<'_, EnvironmentImage> {
        if self.width <= max_width.max(2) {
            return std::borrow::Cow::Borrowed(self);
        }
        let mut img = self.clone();
        while img.width > max_width.max(2) {
            img = img.halved();
        }
        std::borrow::Cow::Owned(img)
    }

    fn halved(&self) -> EnvironmentImage {
        let (w, h) = ((self.width / 2).max(1), (self.height / 2).max(1));
        // Area-weighted (box) resampling, one axis at a time: each output texel averages the
        // source span it covers, counting partly covered texels by their covered fraction, so
        // the mean is kept exactly for odd sizes too. (Texels of an equirectangular map cover
        // solid angles that shrink towards the poles; within one texel pair the difference is
        // second order and ignored.)
        let rows: Vec<Vec<[f64; 3]>> = (0..self.height as usize)
            .map(|y| {
                let row: Vec<[f64; 3]> = self.texels[y * self.width as usize..(y + 1) * self.width as usize]
                    .iter()
                    .map(|t| t.map(|c| c as f64))
                    .collect();
                resample(&row, w as usize)
            })
            .collect();
        let mut texels = vec![[0.0f32; 3]; (w * h) as usize];
        for x in 0..w as usize {
            let column: Vec<[f64; 3]> = rows.iter().map(|r| r[x]).collect();
            for (y, t) in resample(&column, h as usize).into_iter().enumerate() {
                texels[y * w as usize + x] = t.map(|c| c as f32);
            }
        }
        EnvironmentImage { width: w, height: h, texels, label: self.label.clone() }
    }
}

/// `src` resampled to `n` values, each the average of the span of `src` it covers.
fn resample(src: &[[f64; 3]], n: usize) -> Vec<[f64; 3]> {
    let scale = src.len() as f64 / n as f64;
    (0..n)
        .map(|j| {
            let (lo, hi) = (j as f64 * scale, (j + 1) as f64 * scale);
            let mut sum = [0.0; 3];
            for (i, t) in src.iter().enumerate().take(hi.ceil() as usize).skip(lo.floor() as usize) {
                let overlap = (hi.min(i as f64 + 1.0) - lo.max(i as f64)).max(0.0);
                for c in 0..3 {
                    sum[c] += t[c] * overlap;
                }
            }
            sum.map(|v| v / scale)
        })
        .collect()
}

/// The unit direction at equirectangular coordinates (`u`, `v`) in 0..1 (see
/// [`EnvironmentImage`] for the convention).
pub fn direction_of(u: f32, v: f32) -> Vec3 {
    let phi = (u - 0.5) * std::f32::consts::TAU;
    let theta = v * std::f32::consts::PI;
    let (sin_theta, cos_theta) = theta.sin_cos();
    Vec3::new(sin_theta * phi.sin(), cos_theta, -sin_theta * phi.cos())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equirectangular_axes() {
        assert!(direction_of(0.5, 0.0).abs_diff_eq(Vec3::Y, 1e-6), "top row looks up");
        assert!(direction_of(0.5, 1.0).abs_diff_eq(Vec3::NEG_Y, 1e-6), "bottom row looks down");
        assert!(direction_of(0.5, 0.5).abs_diff_eq(Vec3::NEG_Z, 1e-6), "centre looks down -Z");
        assert!(direction_of(0.75, 0.5).abs_diff_eq(Vec3::X, 1e-6), "three quarters looks down +X");
    }

    #[test]
    fn reduction_keeps_the_mean() {
        let img = EnvironmentImage::from_fn(37, 19, "t", |d| Vec3::splat(d.x.max(0.0) * 7.0 + 1.0));
        let mean = |i: &EnvironmentImage| i.texels.iter().map(|t| t[0] as f64).sum::<f64>() / i.texels.len() as f64;
        let r = img.reduced(8);
        assert!(r.width <= 8);
        assert!((mean(&r) - mean(&img)).abs() < 1e-5 * mean(&img), "{} vs {}", mean(&r), mean(&img));
        let even = EnvironmentImage::from_fn(64, 32, "t", |d| Vec3::splat(d.x.max(0.0) * 7.0 + 1.0));
        let r = even.reduced(16);
        assert_eq!((r.width, r.height), (16, 8));
        assert!((mean(&r) - mean(&even)).abs() < 1e-5 * mean(&even));
    }

    #[test]
    fn non_hdr_files_and_garbage_are_named_errors() {
        let e = EnvironmentImage::from_bytes(b"not an image at all", "junk.hdr").unwrap_err().to_string();
        assert!(e.contains("junk.hdr"), "{e}");
        let e = EnvironmentImage::load(Path::new("/nonexistent/sky.exr")).unwrap_err().to_string();
        assert!(e.contains("/nonexistent/sky.exr") && e.contains("cannot open"), "{e}");
        let mut png = Vec::new();
        image::RgbImage::new(4, 2).write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
        let e = EnvironmentImage::from_bytes(&png, "ldr.png").unwrap_err().to_string();
        assert!(e.contains("not a high-dynamic-range format"), "{e}");
    }

    #[test]
    fn radiance_hdr_round_trip() {
        let img = EnvironmentImage::from_fn(16, 8, "t", |d| Vec3::new(d.y.max(0.0) * 100.0, 0.5, 2.0));
        let mut bytes = Vec::new();
        let buf = image::Rgb32FImage::from_raw(16, 8, img.texels.iter().flatten().copied().collect()).unwrap();
        image::DynamicImage::ImageRgb32F(buf)
            .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Hdr)
            .unwrap();
        let back = EnvironmentImage::from_bytes(&bytes, "round.hdr").unwrap();
        assert_eq!((back.width, back.height), (16, 8));
        for (a, b) in back.texels.iter().zip(&img.texels) {
            for c in 0..3 {
                // RGBE keeps 8 bits of mantissa per texel, shared exponent.
                assert!((a[c] - b[c]).abs() <= 0.01 * b[0].max(b[1]).max(b[2]), "{a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn validation_names_the_setting() {
        let e = Environment { intensity: f32::NAN, ..Default::default() };
        assert!(e.validate().unwrap_err().contains("intensity"));
        let e = Environment { background: Background::Blurred(2.0), ..Default::default() };
        assert!(e.validate().unwrap_err().contains("blur"));
        let e = Environment {
            source: EnvironmentSource::Sky(Sky { turbidity: 30.0, ..Default::default() }),
            ..Default::default()
        };
        assert!(e.validate().unwrap_err().contains("turbidity"));
        assert!(Environment::default().validate().is_ok());
        let mut bad = EnvironmentImage::from_fn(4, 2, "short", |_| Vec3::ONE);
        bad.texels.pop();
        let e = Environment::image(Arc::new(bad)).validate().unwrap_err();
        assert!(e.contains("short") && e.contains("7 texels"), "{e}");
        let e = Environment::image(Arc::new(EnvironmentImage::from_fn(0, 0, "empty", |_| Vec3::ONE))).validate();
        assert!(e.unwrap_err().contains("outside"));
    }
}
