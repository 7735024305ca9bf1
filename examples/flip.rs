//! FLIP between two PNGs of one size (NVIDIA's perceptual image difference, through the
//! `nv-flip` crate, as Penumbra's own tests measure): prints the mean and the error-weighted
//! 99.9th percentile. Used by tools/compressed_variants.sh; handy for your own screenshot
//! comparisons: `cargo run --release --example flip -- reference.png test.png`.

fn rgb(path: &str) -> (u32, u32, Vec<u8>) {
    let image = image::open(path).unwrap_or_else(|e| panic!("{path}: {e}")).into_rgb8();
    (image.width(), image.height(), image.into_raw())
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [reference, test] = args.as_slice() else {
        eprintln!("usage: flip REFERENCE.png TEST.png");
        std::process::exit(2);
    };
    let (w, h, a) = rgb(reference);
    let (w2, h2, b) = rgb(test);
    if (w, h) != (w2, h2) {
        eprintln!("{reference} is {w}x{h}, {test} is {w2}x{h2}");
        std::process::exit(2);
    }
    let error = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(w, h, &a),
        nv_flip::FlipImageRgb8::with_data(w, h, &b),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let mut pool = nv_flip::FlipPool::from_image(&error);
    println!("{:.5} {:.5}", pool.mean(), pool.get_percentile(0.999, true));
}
