//! Tests of `environment`.

use super::*;

#[test]
fn the_prefilter_parameters_mirror_the_shaders() {
    crate::pipelines::shader_library::assert_mirrors_wgsl!(
        GpuSourceParams,
        "env_source.wgsl",
        [],
        "SourceParams",
        [perez_lum, perez_x, perez_y, perez_e, zenith, sun, studio, mode, face_size]
    );
    crate::pipelines::shader_library::assert_mirrors_wgsl!(
        GpuFilterParams,
        "env_filter.wgsl",
        [],
        "FilterParams",
        [roughness, sample_count, source_size, face_size, source_levels]
    );
}

#[test]
fn gpu_environment_mirrors_the_shaders_parameters() {
    crate::pipelines::shader_library::assert_mirrors_wgsl!(
        GpuEnvironment,
        "forward.wgsl",
        ["IBL"],
        "EnvironmentParams",
        [rotation, intensity, max_lod, background_lod]
    );
}

#[test]
fn settings_are_range_checked() {
    assert!(EnvironmentSettings::default().validate().is_ok());
    let size = |s| EnvironmentSettings { cube_size: Some(s), ..Default::default() };
    assert!(size(100).validate().unwrap_err().contains("power of two"));
    assert!(size(16).validate().is_err(), "too small for six roughness levels");
    assert_eq!(EnvironmentSettings::default().cube_size_for(true), AUTO_CUBE_CPU);
    assert_eq!(EnvironmentSettings::default().cube_size_for(false), AUTO_CUBE_GPU);
    assert_eq!(size(64).cube_size_for(false), 64);
    assert!(EnvironmentSettings { specular_samples: Some(0), ..Default::default() }.validate().is_err());
    assert_eq!(EnvironmentSettings::default().specular_samples_for(true), AUTO_SAMPLES_STUDIO);
    assert_eq!(EnvironmentSettings::default().specular_samples_for(false), AUTO_SAMPLES);
    assert_eq!(EnvironmentSettings { specular_samples: Some(7), ..Default::default() }.specular_samples_for(true), 7);
}

#[test]
fn auto_source_is_the_sky_with_a_sun_and_the_studio_without() {
    let env = Environment::default();
    assert!(matches!(resolve(&env, None), (Source::Studio, s) if s == 1.0));
    let (src, scale) = resolve(&env, Some((Vec3::new(0.0, 1.0, 1.0).normalize(), 100_000.0)));
    assert!(matches!(src, Source::Sky(_)) && scale > 1000.0);
    let studio = Environment { source: EnvironmentSource::Studio, ..Default::default() };
    assert!(matches!(resolve(&studio, Some((Vec3::Y, 5.0))).0, Source::Studio));
}

#[test]
fn sun_brightness_alone_does_not_change_the_maps() {
    let env = Environment::default();
    let dir = Vec3::new(0.3, 0.7, 0.2).normalize();
    // Not a power-of-two ratio: float rounding must not reach what shapes the maps.
    for (l1, l2) in [(3.0, 7.0), (4.0, 3.0), (10.0, 20.0)] {
        let (a, sa) = resolve(&env, Some((dir, l1)));
        let (b, sb) = resolve(&env, Some((dir, l2)));
        assert_eq!(a, b, "{l1} lux vs {l2} lux");
        assert!((sb / sa - l2 / l1).abs() < 1e-5);
    }
    let (a, _) = resolve(&env, Some((dir, 10.0)));
    let (c, _) = resolve(&env, Some((Vec3::new(0.3, 0.6, 0.2).normalize(), 10.0)));
    assert_ne!(a, c);
}

#[test]
fn very_bright_images_are_stored_scaled() {
    let img = EnvironmentImage::from_fn(8, 4, "sun", |d| Vec3::splat(if d.y > 0.9 { 1e6 } else { 1.0 }));
    assert!((image_scale(&img) - 1e6 / 60_000.0).abs() < 1e-2);
    let dim = EnvironmentImage::from_fn(8, 4, "dim", |_| Vec3::ONE);
    assert_eq!(image_scale(&dim), 1.0);
}
