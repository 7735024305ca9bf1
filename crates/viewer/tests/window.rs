//! `penumbra view` in a real window: an Xvfb X server, the viewer on lavapipe, input from
//! xdotool (the XTEST extension, so the viewer sees real pointer and key events) and the
//! window's pixels read back from the X server.
//!
//! One viewer runs through the whole script (startup on a CPU rasteriser is the slow part):
//! first frame against a golden (loosely: the panels' text may render differently), a
//! horizontal drag of half a turn against a headless render from behind, a scroll zoom, F12,
//! opening a broken file, resizes down to a few pixels, the F2 axes, and Esc. Needs `Xvfb` and `xdotool`
//! (Debian: `apt-get install -y xvfb xdotool`); without them the test fails saying so.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use x11rb::protocol::xproto::{ConnectionExt, ImageFormat};

const W: u32 = 320;
const H: u32 = 240;
/// `--background color`: the viewer's clear colour after tonemapping, so the model is whatever
/// differs from it.
const BACKGROUND_TOLERANCE: i32 = 12;

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn need(tool: &str) {
    let found =
        Command::new("sh").arg("-c").arg(format!("command -v {tool}")).output().is_ok_and(|o| o.status.success());
    assert!(
        found,
        "{tool} is not installed: the window tests need Xvfb and xdotool (Debian: apt-get install -y xvfb xdotool)"
    );
}

/// An Xvfb server on a free display number. Tests in this file run in parallel: each takes its
/// own numbers from a counter, and a server that exits (the number was taken after all) is
/// passed over.
fn xvfb() -> (Killed, String) {
    use std::sync::atomic::{AtomicU32, Ordering};
    static NEXT: AtomicU32 = AtomicU32::new(0);
    need("Xvfb");
    need("xdotool");
    let base = 90 + (std::process::id() % 200) * 4;
    for _ in 0..50 {
        let n = base + NEXT.fetch_add(1, Ordering::Relaxed);
        if Path::new(&format!("/tmp/.X{n}-lock")).exists() {
            continue;
        }
        let display = format!(":{n}");
        let child = Command::new("Xvfb")
            .args([&display, "-screen", "0", "1024x768x24", "-nolisten", "tcp"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb starts");
        let mut server = Killed(child);
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            if server.0.try_wait().expect("wait").is_some() {
                break;
            }
            if x11rb::connect(Some(&display)).is_ok() {
                // Connected, and to our own server only if it is still running.
                std::thread::sleep(Duration::from_millis(200));
                if server.0.try_wait().expect("wait").is_none() {
                    return (server, display);
                }
                break;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }
    panic!("no Xvfb display could be started");
}

struct Viewer {
    display: String,
    process: Killed,
    window: u32,
    log: PathBuf,
}

impl Viewer {
    /// Starts `penumbra view ARGS` on `display` (extra environment in `env`), logging to
    /// `dir/viewer.log`, and finds its window.
    fn start(display: &str, dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Viewer {
        let log = dir.join("viewer.log");
        let child = penumbra()
            .arg("view")
            .args(args)
            .env("DISPLAY", display)
            .env_remove("WAYLAND_DISPLAY")
            .env("XDG_CONFIG_HOME", dir.join("config"))
            .env("RUST_LOG", "info")
            .envs(env.iter().copied())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .expect("the viewer starts");
        let mut viewer = Viewer { display: display.to_owned(), process: Killed(child), window: 0, log };
        let found = Command::new("xdotool")
            .args(["search", "--sync", "--name", "^penumbra"])
            .env("DISPLAY", display)
            .output()
            .expect("xdotool search");
        viewer.window = String::from_utf8_lossy(&found.stdout)
            .lines()
            .next()
            .and_then(|l| l.trim().parse().ok())
            .unwrap_or_else(|| panic!("no viewer window appeared; log:\n{}", viewer.log()));
        viewer
    }

    fn xdotool(&self, args: &[&str]) {
        let o = Command::new("xdotool").args(args).env("DISPLAY", &self.display).output().expect("xdotool runs");
        assert!(o.status.success(), "xdotool {args:?}: {}", String::from_utf8_lossy(&o.stderr));
    }

    fn alive(&mut self) -> bool {
        self.process.0.try_wait().expect("wait").is_none()
    }

    fn log(&self) -> String {
        let mut s = String::new();
        let _ = std::fs::File::open(&self.log).and_then(|mut f| f.read_to_string(&mut s));
        s
    }

    /// The window's pixels as RGBA8, with its size.
    fn capture(&self) -> (Vec<u8>, u32, u32) {
        let (conn, _) = x11rb::connect(Some(&self.display)).expect("connect to Xvfb");
        let g = conn.get_geometry(self.window).unwrap().reply().unwrap();
        let image = conn
            .get_image(ImageFormat::Z_PIXMAP, self.window, 0, 0, g.width, g.height, !0)
            .unwrap()
            .reply()
            .expect("GetImage of the viewer's window");
        // Depth 24 at 32 bits per pixel, little-endian: B, G, R, unused.
        let rgba = image.data.chunks_exact(4).flat_map(|p| [p[2], p[1], p[0], 255]).collect();
        (rgba, g.width as u32, g.height as u32)
    }

    /// As [`Viewer::settled`], without asking for the model to be visible (a view from close
    /// up may show no background to tell it from).
    fn settled_any(&mut self, what: &str) -> (Vec<u8>, u32, u32) {
        let deadline = Instant::now() + Duration::from_secs(90);
        let mut last = self.capture();
        loop {
            std::thread::sleep(Duration::from_millis(700));
            assert!(self.alive(), "the viewer exited during {what}; its log:\n{}", self.log());
            let next = self.capture();
            if next == last {
                return next;
            }
            assert!(Instant::now() < deadline, "{what}: the window never settled; log:\n{}", self.log());
            last = next;
        }
    }

    /// [`Self::settled`], again while the window still shows `before` (for up to 30 s): for input
    /// whose effect a loaded machine may draw after the window first holds still.
    fn settled_unlike(&mut self, before: &(Vec<u8>, u32, u32), what: &str) -> (Vec<u8>, u32, u32) {
        let deadline = Instant::now() + Duration::from_secs(30);
        let mut frame = self.settled(what);
        while &frame == before && Instant::now() < deadline {
            frame = self.settled(what);
        }
        frame
    }

    /// Captures until two in a row match (the camera has settled and the frame is drawn), once
    /// the first scene has loaded: on a loaded machine the loading panel can hold still for
    /// longer than the capture interval.
    fn settled(&mut self, what: &str) -> (Vec<u8>, u32, u32) {
        let deadline = Instant::now() + Duration::from_secs(90);
        // The viewer logs "loaded NAME: imported in .. s, staged in .. s" (with colour codes).
        while !self.log().contains(", staged in ") {
            assert!(self.alive(), "the viewer exited during {what}; its log:\n{}", self.log());
            assert!(Instant::now() < deadline, "{what}: the scene never loaded; log:\n{}", self.log());
            std::thread::sleep(Duration::from_millis(100));
        }
        let mut last = self.capture();
        loop {
            std::thread::sleep(Duration::from_millis(700));
            assert!(self.alive(), "the viewer exited during {what}; its log:\n{}", self.log());
            let next = self.capture();
            if next == last && model_box(&next).is_some() {
                return next;
            }
            assert!(Instant::now() < deadline, "{what}: the window never settled; log:\n{}", self.log());
            last = next;
        }
    }
}

impl Viewer {
    /// Where the viewer last said it draws the scene: (x, y, width, height) in the window.
    fn viewport(&self) -> (u32, u32, u32, u32) {
        let log = self.log();
        let line = log
            .lines()
            .rev()
            .find(|l| l.contains("viewport at ("))
            .unwrap_or_else(|| panic!("no viewport logged:\n{log}"));
        let nums: Vec<u32> =
            line.split(|c: char| !c.is_ascii_digit()).filter(|s| !s.is_empty()).map(|s| s.parse().unwrap()).collect();
        // "... viewport at (X, Y), WxH of the AxB window (left L, right R)": the last eight.
        let n = &nums[nums.len() - 8..];
        (n[0], n[1], n[2], n[3])
    }

    /// Seconds of CPU the viewer has used (user + system).
    fn cpu_seconds(&self) -> f64 {
        let stat =
            std::fs::read_to_string(format!("/proc/{}/stat", self.process.0.id())).expect("the viewer's /proc stat");
        // Fields after the command's closing parenthesis; utime and stime are the 12th and 13th.
        let fields: Vec<&str> = stat.rsplit_once(')').unwrap().1.split_whitespace().collect();
        let ticks: f64 = fields[11].parse::<f64>().unwrap() + fields[12].parse::<f64>().unwrap();
        ticks / 100.0
    }
}

/// The rows and columns of `frame` inside `rect`, as a tightly packed RGBA8 image.
fn crop((rgba, w, _): &(Vec<u8>, u32, u32), (x, y, cw, ch): (u32, u32, u32, u32)) -> Vec<u8> {
    let mut out = Vec::with_capacity((cw * ch * 4) as usize);
    for row in y..y + ch {
        let start = ((row * w + x) * 4) as usize;
        out.extend_from_slice(&rgba[start..start + (cw * 4) as usize]);
    }
    out
}

/// FLIP mean of two images of the same size.
fn flip_mean(a: &[u8], b: &[u8], w: u32, h: u32) -> f32 {
    flip_rows(a, b, w, 0, h)
}

fn penumbra() -> Command {
    Command::new(env!("CARGO_BIN_EXE_penumbra"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("window").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Rows the model is looked for in: below the menu bar, above the status line.
const TOP: u32 = 30;
const BOTTOM: u32 = 24;

/// Bounding box (x0, y0, x1, y1) of the pixels that differ from the background's colour
/// (sampled at the window's left edge), between the menu bar and the status line.
fn model_box((rgba, w, h): &(Vec<u8>, u32, u32)) -> Option<(u32, u32, u32, u32)> {
    if *h <= TOP + BOTTOM {
        return None;
    }
    let background = &rgba[((h / 2) * w + 1) as usize * 4..][..3];
    let mut b: Option<(u32, u32, u32, u32)> = None;
    for y in TOP..(h - BOTTOM) {
        for x in 0..*w {
            let p = &rgba[((y * w + x) * 4) as usize..][..3];
            if p.iter().zip(background).any(|(a, c)| (*a as i32 - *c as i32).abs() > BACKGROUND_TOLERANCE) {
                b = Some(b.map_or((x, y, x, y), |(x0, y0, x1, y1)| (x0.min(x), y0.min(y), x1.max(x), y1.max(y))));
            }
        }
    }
    b
}

/// Whether the box is clear of the searched region's edges (the whole model is measured).
fn inside(b: (u32, u32, u32, u32), w: u32, h: u32) -> bool {
    b.0 > 1 && b.1 > TOP && b.2 < w - 2 && b.3 < h - BOTTOM - 1
}

/// FLIP mean over the window's middle rows (the menu bar and the status line left out).
fn flip_middle(a: &[u8], b: &[u8], w: u32, h: u32) -> f32 {
    flip_rows(a, b, w, TOP, h - BOTTOM)
}

/// FLIP mean over rows `y0..y1`.
fn flip_rows(a: &[u8], b: &[u8], w: u32, y0: u32, y1: u32) -> f32 {
    let rows = |rgba: &[u8]| -> Vec<u8> {
        rgba[(y0 * w * 4) as usize..(y1 * w * 4) as usize].chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect()
    };
    let reference = nv_flip::FlipImageRgb8::with_data(w, y1 - y0, &rows(a));
    let test = nv_flip::FlipImageRgb8::with_data(w, y1 - y0, &rows(b));
    let error = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    nv_flip::FlipPool::from_image(&error).mean()
}

fn golden(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/goldens/viewer").join(name)
}

fn save(path: &Path, rgba: &[u8], w: u32, h: u32) {
    image::save_buffer(path, rgba, w, h, image::ColorType::Rgba8).unwrap();
}

#[test]
fn viewer_in_a_window_orbits_zooms_saves_and_survives_bad_files_and_resizes() {
    let (_server, display) = xvfb();
    let dir = scratch("script");
    let shots = dir.join("shots");
    let common = ["--size", "320x240", "--background", "color", "--msaa", "4"];
    let mut viewer =
        Viewer::start(&display, &dir, &[&common[..], &["--screenshot-dir", shots.to_str().unwrap()]].concat(), &[]);
    // Without a window manager nothing gives the window the keyboard; the pointer rests in its
    // middle so that wheel events reach the scene.
    viewer.xdotool(&["windowfocus", "--sync", &viewer.window.to_string()]);
    viewer.xdotool(&["mousemove", "--window", &viewer.window.to_string(), "160", "140"]);

    // First frame: the embedded default scene, as the golden shows it.
    let first = viewer.settled("the first frame");
    assert_eq!((first.1, first.2), (W, H), "the window is not the asked size");
    let golden_path = golden("first_frame.png");
    if std::env::var_os("PENUMBRA_UPDATE_GOLDENS").is_some() {
        save(&golden_path, &first.0, W, H);
    }
    let expected = image::open(&golden_path).expect("tests/goldens/viewer/first_frame.png").into_rgba8();
    let error = flip_middle(expected.as_raw(), &first.0, W, H);
    save(&dir.join("first_frame.png"), &first.0, W, H);
    assert!(error < 0.05, "first frame: FLIP {error:.4} against {} (see {})", golden_path.display(), dir.display());

    // The scene is drawn below the menu bar, in the whole width (no panels are open).
    let viewport = viewer.viewport();
    let (_, vy, vw, vh) = viewport;
    assert!(vy > 0 && vy < 40 && vw == W && vy + vh == H, "viewport {viewport:?} in a {W}x{H} window");

    // A horizontal drag of one viewport height turns the camera half way round the vertical
    // axis: from the default view (yaw 35°, pitch 25°) to the one from behind (yaw 215°),
    // which a headless render at the viewport's size shows.
    let win = viewer.window.to_string();
    viewer.xdotool(&["mousemove", "--window", &win, "40", "140", "mousedown", "1"]);
    for x in (40..=40 + vh).step_by(15).chain([40 + vh]).skip(1) {
        viewer.xdotool(&["mousemove", "--window", &win, &x.to_string(), "140"]);
    }
    viewer.xdotool(&["mouseup", "1"]);
    let behind = viewer.settled("the drag");
    save(&dir.join("behind.png"), &behind.0, W, H);
    let reference = dir.join("behind_headless.png");
    let o = penumbra()
        .arg("render")
        // The embedded default scene is this file.
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/DamagedHelmet.glb"))
        .arg("--out")
        .arg(&reference)
        .args(["--background", "color", "--msaa", "4", "--size", &format!("{vw}x{vh}")])
        .args(["--camera", "orbit:215:25"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let reference = image::open(&reference).unwrap().into_rgba8();
    let turned = flip_mean(reference.as_raw(), &crop(&behind, viewport), vw, vh);
    let unmoved = flip_mean(&crop(&first, viewport), &crop(&behind, viewport), vw, vh);
    assert!(
        turned < 0.06 && unmoved > 2.0 * turned,
        "after the drag: FLIP {turned:.4} against the view from behind, {unmoved:.4} against the first frame"
    );

    // Scroll down: farther, so the model covers less of the window (and stays inside it
    // through the resizes below).
    let before = model_box(&behind).expect("model visible");
    viewer.xdotool(&["mousemove", "--window", &win, "160", "140", "click", "5", "click", "5", "click", "5"]);
    let farther = viewer.settled("the zoom");
    let after = model_box(&farther).expect("model visible");
    let width = |b: (u32, u32, u32, u32)| (b.2 - b.0) as f32;
    assert!(width(after) < 0.8 * width(before), "zoom: model width {} → {}", width(before), width(after));
    assert!(inside(after, W, H), "zoomed out, the model still touches the edge: {after:?}");

    // Resizes, down to a few pixels: no crash, and the model keeps its proportions.
    let aspect = |b: (u32, u32, u32, u32)| (b.2 - b.0) as f32 / (b.3 - b.1) as f32;
    let reference_aspect = aspect(after);
    for (w, h) in [(480, 200), (8, 8), (1, 1), (200, 300), (320, 240)] {
        viewer.xdotool(&["windowsize", "--sync", &win, &w.to_string(), &h.to_string()]);
        std::thread::sleep(Duration::from_millis(800));
        assert!(viewer.alive(), "the viewer exited at {w}×{h}; log:\n{}", viewer.log());
        if w >= 200 {
            let frame = viewer.settled(&format!("the resize to {w}×{h}"));
            assert_eq!((frame.1, frame.2), (w, h));
            let b = model_box(&frame).expect("model visible");
            assert!(inside(b, w, h), "{w}×{h}: the model reaches the edge: {b:?}");
            let a = aspect(b);
            assert!(
                (a / reference_aspect - 1.0).abs() < 0.1,
                "{w}×{h}: model aspect {a:.3}, was {reference_aspect:.3}"
            );
        }
    }
    let closer = viewer.settled("the last resize");

    // Hidden and shown again (unmapped: what minimising does without a window manager): the
    // viewer keeps running and shows the same frame.
    viewer.xdotool(&["windowunmap", "--sync", &win]);
    std::thread::sleep(Duration::from_millis(1500));
    assert!(viewer.alive(), "the viewer exited while hidden; log:\n{}", viewer.log());
    viewer.xdotool(&["windowmap", "--sync", &win]);
    viewer.xdotool(&["windowfocus", "--sync", &win]);
    let shown = viewer.settled("showing the window again");
    save(&dir.join("before_hiding.png"), &closer.0, W, H);
    save(&dir.join("shown_again.png"), &shown.0, W, H);
    let changed = flip_middle(&closer.0, &shown.0, W, H);
    assert!(changed < 0.005, "the frame changed while the window was hidden: FLIP {changed:.4}");

    // F2 draws the world axes (X red, Y green, Z blue); F2 again takes them away.
    let dominant = |rgba: &[u8], c: usize| {
        rgba.chunks_exact(4).filter(|p| (0..3).filter(|&k| k != c).all(|k| p[c] as i32 > p[k] as i32 + 60)).count()
    };
    let plain = viewer.settled("before the axes");
    viewer.xdotool(&["key", "F2"]);
    let axes = viewer.settled("the world axes");
    // The camera looks along Z here, so the blue Z axis is seen end-on: X and Y are counted.
    for (c, name) in [(0, "red X"), (1, "green Y")] {
        let (before, after) = (dominant(&plain.0, c), dominant(&axes.0, c));
        assert!(after >= before + 5, "F2: {name} pixels {before} → {after}");
    }
    viewer.xdotool(&["key", "F2"]);
    let again = viewer.settled("the axes switched off");
    assert!(again == plain, "F2 twice does not give the frame back");

    // A click on the model selects it: a yellow box round it. A click
    // on empty background clears the selection and the box goes.
    let yellow = |rgba: &[u8]| {
        rgba.chunks_exact(4).filter(|p| p[0] > 150 && p[1] > 120 && (p[2] as i32) < p[1] as i32 - 80).count()
    };
    viewer.xdotool(&["mousemove", "--window", &win, "160", "132", "click", "1"]);
    let selected = viewer.settled("the selection");
    save(&dir.join("selected.png"), &selected.0, W, H);
    let b = model_box(&closer).expect("model visible");
    let boxed = |rgba: &[u8]| {
        let mut n = 0;
        for y in b.1..=b.3 {
            for x in b.0..=b.2 {
                let p = &rgba[((y * W + x) * 4) as usize..][..3];
                n += usize::from(p[0] > 150 && p[1] > 120 && (p[2] as i32) < p[1] as i32 - 80);
            }
        }
        n
    };
    assert!(yellow(&selected.0) >= yellow(&closer.0) + 20, "no selection box after a click on the model");
    assert!(boxed(&selected.0) > 0, "the selection box is not round the model");
    viewer.xdotool(&["mousemove", "--window", &win, "300", "200", "click", "1"]);
    let cleared = viewer.settled("clearing the selection");
    let in_scene = |rgba: &[u8]| boxed(rgba);
    assert_eq!(in_scene(&cleared.0), boxed(&closer.0), "the box stays after clicking on nothing");

    // F12 writes the scene, without the panels and without the selection box, as a PNG of the
    // window's size (the model is selected again first; before, the box was in the file).
    viewer.xdotool(&["mousemove", "--window", &win, "160", "132", "click", "1"]);
    let reselected = viewer.settled("the selection again");
    assert!(boxed(&reselected.0) > 0, "the selection box is back");
    viewer.xdotool(&["key", "F12"]);
    let shot = shots.join("penumbra-0001.png");
    let deadline = Instant::now() + Duration::from_secs(30);
    while !shot.exists() || image::open(&shot).is_err() {
        assert!(Instant::now() < deadline, "F12 wrote no {}; log:\n{}", shot.display(), viewer.log());
        std::thread::sleep(Duration::from_millis(200));
    }
    let png = image::open(&shot).unwrap().into_rgba8();
    assert_eq!((png.width(), png.height()), (vw, vh), "the screenshot is not the viewport's size");
    let shown = flip_mean(png.as_raw(), &crop(&closer, viewport), vw, vh);
    assert!(shown < 0.02, "the screenshot differs from the window's scene: FLIP {shown:.4}");
    let yellow_in = |rgba: &[u8]| yellow(rgba);
    assert_eq!(yellow_in(png.as_raw()), yellow_in(&crop(&closer, viewport)), "the selection box is in the screenshot");
    viewer.xdotool(&["mousemove", "--window", &win, "300", "200", "click", "1"]);
    viewer.settled("clearing the selection again");

    // Opening a broken file (Ctrl+L, type its path, Enter) reports it and keeps the scene.
    let broken = dir.join("broken.glb");
    std::fs::write(&broken, b"glTF\x02\x00\x00\x00not really a binary glTF").unwrap();
    viewer.xdotool(&["key", "ctrl+l"]);
    std::thread::sleep(Duration::from_millis(1500));
    viewer.xdotool(&["type", "--delay", "20", broken.to_str().unwrap()]);
    viewer.xdotool(&["key", "Return"]);
    let deadline = Instant::now() + Duration::from_secs(30);
    while !viewer.log().contains("broken.glb") {
        assert!(viewer.alive(), "the viewer exited on a broken file; log:\n{}", viewer.log());
        assert!(Instant::now() < deadline, "no error named broken.glb; log:\n{}", viewer.log());
        std::thread::sleep(Duration::from_millis(200));
    }
    let line = viewer.log().lines().find(|l| l.contains("broken.glb")).unwrap().to_owned();
    assert!(line.contains("ERROR"), "the broken file was not reported as an error: {line}");
    assert!(viewer.alive());

    // The error stays in a dialog: the first Esc closes it (the viewer keeps running), the
    // second quits, cleanly.
    let with_dialog = viewer.settled("the error dialog");
    viewer.xdotool(&["key", "Escape"]);
    let without = viewer.settled("the error dialog closed");
    assert!(viewer.alive(), "Esc with the error dialog open quit the viewer");
    assert!(with_dialog != without, "Esc did not close the error dialog");
    viewer.xdotool(&["key", "Escape"]);
    let deadline = Instant::now() + Duration::from_secs(20);
    let status = loop {
        if let Some(s) = viewer.process.0.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < deadline, "Esc did not quit the viewer");
        std::thread::sleep(Duration::from_millis(100));
    };
    assert!(status.success(), "the viewer exited with {status}; log:\n{}", viewer.log());
}

/// HiDPI: at scale factor 2 a window of 160×120 logical pixels has a 320×240 framebuffer, and the
/// scene is rendered at that resolution (its viewport matches a headless render of its size),
/// not upscaled.
#[test]
fn viewer_renders_at_the_physical_size_of_a_hidpi_window() {
    let (_server, display) = xvfb();
    let dir = scratch("hidpi");
    let args = ["--size", "160x120", "--background", "color", "--msaa", "4"];
    let mut viewer = Viewer::start(&display, &dir, &args, &[("WINIT_X11_SCALE_FACTOR", "2")]);
    let frame = viewer.settled("the first frame at scale 2");
    assert_eq!((frame.1, frame.2), (W, H), "the framebuffer does not follow the physical size");
    // The scene is drawn below the menu bar (twice as tall at scale 2), in physical pixels.
    let viewport = viewer.viewport();
    let (_, vy, vw, vh) = viewport;
    assert!(vw == W && vy > 40 && vy < 80 && vy + vh == H, "viewport {viewport:?} at scale 2");
    let reference = dir.join("headless.png");
    let o = penumbra()
        .arg("render")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/DamagedHelmet.glb"))
        .arg("--out")
        .arg(&reference)
        .args(["--size", &format!("{vw}x{vh}"), "--background", "color", "--msaa", "4"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let reference = image::open(&reference).unwrap().into_rgba8();
    save(&dir.join("window.png"), &frame.0, W, H);
    let error = flip_mean(reference.as_raw(), &crop(&frame, viewport), vw, vh);
    assert!(error < 0.03, "HiDPI viewport vs headless {vw}×{vh}: FLIP {error:.4} (see {})", dir.display());
}

/// Surface and device loss (issue 11), injected by `surface.rs`: every third image request
/// reports the surface lost (`PENUMBRA_DEBUG_SURFACE_LOSS=3`) and the 120th destroys the GPU
/// device (`PENUMBRA_DEBUG_DEVICE_LOSS=120`), late enough that the scene has usually loaded (a
/// still viewer asks for few images while it loads; a loss during the load leaves no scene to
/// move: the staged scene then starts on the new device). The viewer creates the surface again each time, makes a new device, and keeps
/// showing the scene as the golden shows it.
#[test]
fn viewer_survives_lost_surfaces_and_a_lost_device() {
    let (_server, display) = xvfb();
    let dir = scratch("surface-loss");
    let args = ["--size", "320x240", "--background", "color", "--msaa", "4"];
    let env = [("PENUMBRA_DEBUG_SURFACE_LOSS", "3"), ("PENUMBRA_DEBUG_DEVICE_LOSS", "120")];
    let mut viewer = Viewer::start(&display, &dir, &args, &env);
    let expected = image::open(golden("first_frame.png")).unwrap().into_rgba8();
    let shows_scene = |viewer: &mut Viewer, what: &str| {
        // Loading runs beside the window (its progress panel shows meanwhile): wait for the scene.
        let deadline = Instant::now() + Duration::from_secs(90);
        loop {
            let frame = viewer.settled(what);
            let error = flip_middle(expected.as_raw(), &frame.0, W, H);
            if error < 0.05 {
                return;
            }
            save(&dir.join("lost.png"), &frame.0, W, H);
            assert!(
                Instant::now() < deadline,
                "{what}: FLIP {error:.4} against the first-frame golden (see {})",
                dir.display()
            );
        }
    };
    shows_scene(&mut viewer, "frames between lost surfaces");
    // A still viewer draws (and asks for surface images) only when something changes: the
    // pointer moving over it keeps frames coming until the device is lost and replaced.
    let win = viewer.window.to_string();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !viewer.log().contains("the window has a new GPU device") {
        assert!(viewer.alive(), "the viewer exited; log:\n{}", viewer.log());
        assert!(Instant::now() < deadline, "the device was not replaced; log:\n{}", viewer.log());
        for x in [150, 170] {
            viewer.xdotool(&["mousemove", "--window", &win, &x.to_string(), "200"]);
        }
    }
    shows_scene(&mut viewer, "frames on the new device");
    let log = viewer.log();
    let recreated = log.matches("created it again").count();
    assert!(recreated >= 3, "the surface was not lost and recreated repeatedly ({recreated} times); log:\n{log}");
    assert!(viewer.alive(), "the viewer exited; log:\n{log}");
}

/// The UI keeps its own input and its panels dock (issue 47), at 640×400 with every panel open:
/// the panels sit beside the scene (the scene is drawn only in what they leave, and the whole
/// model is in it); Esc with a menu open closes the menu, not the viewer; a click that closes a
/// menu does not reach the scene (the selection stays); the file browser opens (Ctrl+O) and Esc
/// closes it; a still window uses next to no CPU; sixty wheel notches in never take the camera
/// through the model's surface.
#[test]
fn viewer_ui_keeps_its_input_and_docks_its_panels() {
    let (_server, display) = xvfb();
    let dir = scratch("ui");
    let (w, h) = (640u32, 400u32);
    let args = [
        "--size",
        "640x400",
        "--background",
        "color",
        "--msaa",
        "1",
        "--panels",
        "stats,tree,inspector,settings,environment",
    ];
    let mut viewer = Viewer::start(&display, &dir, &args, &[]);
    let win = viewer.window.to_string();
    viewer.xdotool(&["windowfocus", "--sync", &win]);
    let docked = viewer.settled("the first frame with every panel");
    save(&dir.join("docked.png"), &docked.0, w, h);
    assert_eq!((docked.1, docked.2), (w, h));
    // The loading panel covers the whole load: from the file read, it says it prepares the
    // first frame (staging and the shader compiles of that frame come after), and the scene
    // replaces it only with its first frame on screen.
    let log = viewer.log();
    let at = |what: &str| log.find(what).unwrap_or_else(|| panic!("no {what:?} in the log:\n{log}"));
    assert!(
        at("preparing the first frame of") < at(", staged in ") && at(", staged in ") < at("on screen, "),
        "the load's steps are out of order:\n{log}"
    );

    // Docked: a left and a right column and the scene between them, inside the window.
    let viewport = viewer.viewport();
    let (vx, vy, vw, vh) = viewport;
    assert!(vx >= 120 && vx + vw <= w - 120 && vw >= w / 3, "panels and viewport: {viewport:?} of {w}x{h}");
    assert!(vy > 0 && vy + vh == h, "viewport {viewport:?}");
    // The panels are opaque UI, not scene: their columns hold the panel colours, with no
    // model pixels under them; the model is wholly inside the viewport.
    let scene_only = crop(&docked, viewport);
    let b = model_box(&(scene_only.clone(), vw, vh)).expect("the model is in the viewport");
    assert!(inside(b, vw, vh), "the model reaches the viewport's edge: {b:?} in {vw}x{vh}");
    let panel_fill = |x0: u32, x1: u32| {
        let (mut dark, mut n) = (0, 0);
        for y in (vy + 10..h - 10).step_by(7) {
            for x in (x0..x1).step_by(7) {
                let p = &docked.0[((y * w + x) * 4) as usize..][..3];
                dark += usize::from(p.iter().all(|&c| c < 70));
                n += 1;
            }
        }
        dark as f32 / n as f32
    };
    assert!(panel_fill(2, vx - 2) > 0.6, "the left column is not a panel");
    assert!(panel_fill(vx + vw + 2, w - 2) > 0.6, "the right column is not a panel");

    // A still window: no frames, next to no CPU.
    let before = viewer.cpu_seconds();
    std::thread::sleep(Duration::from_secs(3));
    let idle = viewer.cpu_seconds() - before;
    assert!(idle < 0.15, "a still window used {idle:.2} s of CPU in 3 s");

    // Select the model (a click in the middle of the viewport): the yellow box.
    let (cx, cy) = (vx + vw / 2, vy + vh / 2);
    let yellow = |rgba: &[u8]| {
        rgba.chunks_exact(4).filter(|p| p[0] > 150 && p[1] > 120 && (p[2] as i32) < p[1] as i32 - 80).count()
    };
    viewer.xdotool(&["mousemove", "--window", &win, &cx.to_string(), &cy.to_string(), "click", "1"]);
    let selected = viewer.settled("the selection");
    let boxed = yellow(&crop(&selected, viewport));
    assert!(boxed > 20, "no selection box after a click on the model");

    // Esc with a menu open closes the menu and nothing else.
    viewer.xdotool(&["mousemove", "--window", &win, "55", "12", "click", "1"]);
    let menu = viewer.settled_unlike(&selected, "the View menu");
    assert!(menu != selected, "the View menu did not open");
    viewer.xdotool(&["key", "Escape"]);
    // The pointer back where it was for the comparison (it highlights what it hovers).
    viewer.xdotool(&["mousemove", "--window", &win, &cx.to_string(), &cy.to_string()]);
    let closed = viewer.settled("Esc on the menu");
    assert!(viewer.alive(), "Esc with a menu open quit the viewer; log:\n{}", viewer.log());
    // The stats panel's numbers change with every frame: compared left of it.
    let steady = (0, 0, vx + vw, h);
    save(&dir.join("selected.png"), &selected.0, w, h);
    save(&dir.join("menu_closed.png"), &closed.0, w, h);
    assert!(crop(&closed, steady) == crop(&selected, steady), "Esc did not close the menu (or changed the scene)");

    // A click on the scene while a menu is open closes the menu, and the scene does not see it:
    // the selection stays (before, it was cleared by the click).
    viewer.xdotool(&["mousemove", "--window", &win, "55", "12", "click", "1"]);
    // The menu must be open (drawn) before the next click: on a loaded machine both clicks can
    // otherwise reach the viewer before it has run the frame that opens the menu.
    let menu_again = viewer.settled_unlike(&closed, "the View menu again");
    assert!(menu_again != closed, "the View menu did not open again");
    let empty = (vx + vw - 12, vy + 12);
    viewer.xdotool(&["mousemove", "--window", &win, &empty.0.to_string(), &empty.1.to_string(), "click", "1"]);
    let after = viewer.settled("a click beside the menu");
    assert_eq!(yellow(&crop(&after, viewport)), boxed, "the click that closed the menu reached the scene");

    // The file browser: Ctrl+O shows it over the scene, Esc closes it.
    viewer.xdotool(&["key", "ctrl+o"]);
    let browser = viewer.settled("the file browser");
    save(&dir.join("browser.png"), &browser.0, w, h);
    let changed = flip_mean(&crop(&after, viewport), &crop(&browser, viewport), vw, vh);
    assert!(changed > 0.05, "Ctrl+O showed no file browser (FLIP {changed:.4})");
    viewer.xdotool(&["key", "Escape"]);
    let gone = viewer.settled("the file browser closed");
    assert!(viewer.alive(), "Esc in the file browser quit the viewer");
    assert!(crop(&gone, steady) == crop(&after, steady), "Esc did not close the file browser");

    // Sixty notches in, with the pointer on the model: the camera closes in on its surface and
    // stops short of it, so the viewport is filled by the model, not by what is behind it.
    viewer.xdotool(&["mousemove", "--window", &win, &cx.to_string(), &cy.to_string()]);
    for _ in 0..6 {
        viewer.xdotool(&["click", "--repeat", "10", "--delay", "30", "4"]);
    }
    let near = viewer.settled_any("sixty notches in");
    save(&dir.join("near.png"), &near.0, w, h);
    let scene = crop(&near, viewport);
    let bg = &crop(&docked, viewport)[..3];
    let background_pixels = scene
        .chunks_exact(4)
        .filter(|p| p[..3].iter().zip(bg).all(|(a, c)| (*a as i32 - *c as i32).abs() <= BACKGROUND_TOLERANCE))
        .count();
    let fraction = background_pixels as f32 / (vw * vh) as f32;
    assert!(
        fraction < 0.05,
        "after zooming in, {fraction:.2} of the viewport is background: the camera went through the model"
    );
    assert!(viewer.alive());
}
