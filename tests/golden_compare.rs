//! The golden comparison itself: identical images pass, a changed region fails and leaves the
//! actual image and a FLIP difference image beside the golden, named in the panic message.

mod common;
use common::{Shot, Tolerance, check_golden_in, scratch_dir};

fn gradient(w: u32, h: u32) -> Shot {
    let mut rgba8 = Vec::new();
    for y in 0..h {
        for x in 0..w {
            rgba8.extend_from_slice(&[(x * 255 / w) as u8, (y * 255 / h) as u8, 128, 255]);
        }
    }
    Shot { width: w, height: h, rgba8 }
}

fn write_golden(dir: &std::path::Path, name: &str, shot: &Shot) {
    image::save_buffer(dir.join(format!("{name}.png")), &shot.rgba8, shot.width, shot.height, image::ColorType::Rgba8)
        .unwrap();
}

#[test]
fn identical_images_pass() {
    let dir = scratch_dir("golden-identical");
    let shot = gradient(64, 48);
    write_golden(&dir, "g", &shot);
    check_golden_in(&dir, "g", &shot, Tolerance::default());
    assert!(!dir.join("g.actual.png").exists());
}

#[test]
fn a_changed_region_fails_and_leaves_actual_and_diff_images() {
    let dir = scratch_dir("golden-changed");
    let golden = gradient(64, 48);
    write_golden(&dir, "g", &golden);
    let mut changed = gradient(64, 48);
    // A 12×12 block turned white: about 5 % of the image.
    for y in 10..22 {
        for x in 20..32 {
            let i = ((y * 64 + x) * 4) as usize;
            changed.rgba8[i..i + 3].copy_from_slice(&[255, 255, 255]);
        }
    }
    let result = std::panic::catch_unwind(|| check_golden_in(&dir, "g", &changed, Tolerance::default()));
    let message = match result {
        Ok(()) => panic!("a changed image passed"),
        Err(e) => e.downcast_ref::<String>().cloned().unwrap_or_default(),
    };
    assert!(message.contains("g.actual.png") && message.contains("g.diff.png"), "{message}");
    assert!(dir.join("g.actual.png").exists() && dir.join("g.diff.png").exists());
    let diff = image::open(dir.join("g.diff.png")).unwrap().into_rgb8();
    assert_ne!(diff.get_pixel(25, 15), diff.get_pixel(5, 40), "the diff image highlights the changed block");
}
