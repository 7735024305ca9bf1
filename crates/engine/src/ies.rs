//! IES LM-63 photometric profiles: how a real luminaire's luminous intensity varies with
//! direction, as manufacturers publish it. [`IesProfile::parse`] reads the text format (the
//! 1986, 1991, 1995, 2002 and 2019 revisions), checks it and evaluates it; the renderer samples
//! the uniform grid [`IesProfile::grid`] resamples it to.
//!
//! Data flow: file → [`IesProfile`] (an asset in `Assets<IesProfile>`) → an `IesLight`
//! component names it by handle → extraction snapshots the asset → the light store packs every
//! profile in use into one buffer of [`ProfileGrid`]s → the forward shader looks the light's
//! intensity up by direction.
//!
//! Angles are type C photometry (the kind nearly every interior and street luminaire is
//! measured in): the vertical angle γ runs from 0° at the nadir (the direction the light
//! shines, its local −Z) to 180° at the zenith; the horizontal angle C turns about that axis,
//! counter-clockwise seen from above (from local +Z), with C = 0° along local +X and C = 90°
//! along local +Y. Types A and B (floodlights, automotive) name their angles about a horizontal
//! axis; they are refused with an error rather than shown wrong.
//!
//! What a file may leave out, and how it is filled:
//! - horizontal symmetry, from the range of horizontal angles (LM-63 §4.17): one angle means
//!   the same in every plane; 0–90° is mirrored into all four quadrants; 0–180° and 90–270° are
//!   mirrored across their plane; 0–360° (or any other range starting at 0°) wraps around;
//! - directions beyond the last vertical angle (a downlight measured 0–90°) get no light;
//! - `TILT=INCLUDE` data is read (so the candela values after it are found) but not applied:
//!   it corrects for a lamp burning at another angle than measured, which a renderer does not
//!   know. `TILT=<file>` names a file not read, for the same reason; both are kept in
//!   [`IesProfile::tilt`] so callers can tell.

use std::fmt;
use std::path::Path;

/// The most vertical or horizontal angles a profile may have; real files have at most a few
/// hundred. Checked before anything is allocated.
pub const MAX_ANGLES: usize = 10_000;
/// The most candela values a profile may have.
pub const MAX_VALUES: usize = 1 << 20;

/// A parse or validation failure, naming the file, the line and what was wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct IesError {
    pub file: String,
    /// 1-based; `None` for problems with the file as a whole.
    pub line: Option<usize>,
    pub message: String,
}

/// Which revision of LM-63 the file says it follows (its first line).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IesFormat {
    /// No format line: LM-63-1986.
    Lm63_1986,
    /// `IESNA91`.
    Lm63_1991,
    /// `IESNA:LM-63-1995`.
    Lm63_1995,
    /// `IESNA:LM-63-2002`.
    Lm63_2002,
    /// `IES:LM-63-2019` (or a later `IES:LM-63-…`).
    Lm63_2019,
}

/// The file's lamp tilt data, which is read but not applied (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub enum Tilt {
    None,
    /// `TILT=INCLUDE`: (angle in degrees, output factor) pairs.
    Included {
        geometry: u32,
        angles: Vec<f32>,
        factors: Vec<f32>,
    },
    /// `TILT=<file>`.
    File(String),
}

/// How the horizontal angles cover the full turn (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Symmetry {
    /// One horizontal angle: the same in every plane.
    Axial,
    /// 0–90°: mirrored into all four quadrants.
    Quadrant,
    /// 0–180°: mirrored across the 0–180° plane.
    Bilateral0To180,
    /// 90–270°: mirrored across the 90–270° plane.
    Bilateral90To270,
    /// Starts at 0° and wraps around to 360°.
    None,
}

/// A parsed, validated LM-63 profile.
#[derive(Debug, Clone, PartialEq)]
pub struct IesProfile {
    /// Where it came from, for messages.
    pub label: String,
    pub format: IesFormat,
    /// Keyword lines (`[MANUFAC] Acme`) in file order.
    pub keywords: Vec<(String, String)>,
    pub tilt: Tilt,
    /// Vertical angles γ in degrees, ascending, within 0–180.
    pub vertical_angles: Vec<f32>,
    /// Horizontal angles C in degrees, ascending, within 0–360.
    pub horizontal_angles: Vec<f32>,
    /// Candela, `candela[h * vertical_angles.len() + v]`, with the file's candela multiplier and
    /// ballast factors applied. Negative values in the file (measurement noise) read as 0.
    pub candela: Vec<f32>,
    pub symmetry: Symmetry,
    /// The luminous opening in metres (width, length, height; LM-63's signs for round shapes
    /// kept), for area-light approximations; the renderer treats the luminaire as a point.
    pub opening: [f32; 3],
    /// Input watts as the file gives them.
    pub input_watts: f32,
    grid: ProfileGrid,
}

/// The profile resampled onto a uniform grid the shader can index directly: `rows` vertical
/// angles from 0° to 180° by `180/(rows−1)`, in `columns` horizontal planes from 0° by
/// `360/columns` (wrapping), column-major, each value divided by `peak`.
///
/// The steps are the coarsest of a list of common ones that hold every angle of the file
/// exactly, so the grid contains the file's own samples and bilinear interpolation on it is
/// exactly the file's bilinear interpolation (within f32), with no resampling error. Files whose
/// angles fit no listed step are sampled at the finest step, 0.25°, whose error is measured in
/// the tests.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileGrid {
    pub rows: u32,
    pub columns: u32,
    /// Candela of the brightest direction.
    pub peak: f32,
    pub values: Vec<f32>,
}

/// Steps (degrees) tried for the grid, coarsest first. Each divides 180 and 360.
const GRID_STEPS: [f32; 13] = [45.0, 22.5, 15.0, 10.0, 7.5, 5.0, 4.5, 3.0, 2.5, 2.0, 1.5, 1.0, 0.5];
/// The step used when no listed one holds every angle.
const FINEST_STEP: f32 = 0.25;

impl fmt::Display for IesFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            IesFormat::Lm63_1986 => "LM-63-1986",
            IesFormat::Lm63_1991 => "LM-63-1991",
            IesFormat::Lm63_1995 => "LM-63-1995",
            IesFormat::Lm63_2002 => "LM-63-2002",
            IesFormat::Lm63_2019 => "LM-63-2019",
        })
    }
}

/// The numbers after the TILT line, with the line each started on.
struct Numbers<'a> {
    tokens: Vec<(usize, &'a str)>,
    next: usize,
    file: &'a str,
}

impl<'a> Numbers<'a> {
    fn new(lines: &[(usize, &'a str)], file: &'a str) -> Self {
        let tokens = lines
            .iter()
            .flat_map(|&(n, line)| {
                line.split(|c: char| c.is_whitespace() || c == ',').filter(|t| !t.is_empty()).map(move |t| (n, t))
            })
            .collect();
        Self { tokens, next: 0, file }
    }

    fn err(&self, line: Option<usize>, message: String) -> IesError {
        IesError { file: self.file.to_string(), line, message }
    }

    fn remaining(&self) -> usize {
        self.tokens.len() - self.next
    }

    fn last_line(&self) -> Option<usize> {
        self.tokens.last().map(|t| t.0)
    }

    fn number(&mut self, what: &str) -> Result<f32, IesError> {
        let Some(&(line, token)) = self.tokens.get(self.next) else {
            return Err(self.err(self.last_line(), format!("the file ends where {what} should be")));
        };
        self.next += 1;
        match token.parse::<f32>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.err(Some(line), format!("{what} is {token}, not a finite number"))),
            Err(_) => Err(self.err(Some(line), format!("expected {what}, found \"{token}\""))),
        }
    }

    /// A non-negative whole number no larger than `max`.
    fn count(&mut self, what: &str, max: usize) -> Result<usize, IesError> {
        let line = self.tokens.get(self.next).map(|t| t.0);
        let v = self.number(what)?;
        if v < 0.0 || v.fract() != 0.0 {
            return Err(self.err(line, format!("{what} must be a whole number ≥ 0, found {v}")));
        }
        if v > max as f32 {
            return Err(self.err(line, format!("{what} is {v}; at most {max} are accepted")));
        }
        Ok(v as usize)
    }

    fn list(&mut self, n: usize, what: &str) -> Result<Vec<f32>, IesError> {
        if self.remaining() < n {
            return Err(
                self.err(self.last_line(), format!("the file ends after {} of the {n} {what}", self.remaining()))
            );
        }
        (0..n).map(|i| self.number(&format!("{what} #{}", i + 1))).collect()
    }

    fn line(&self) -> Option<usize> {
        self.tokens.get(self.next).map(|t| t.0)
    }
}

impl IesProfile {
    /// Reads and parses an `.ies` file. Text that is not UTF-8 (Latin-1 keywords are common)
    /// is read with replacement characters; the numbers are ASCII either way.
    pub fn load(path: &Path) -> Result<Self, IesError> {
        let bytes = std::fs::read(path).map_err(|e| IesError {
            file: path.display().to_string(),
            line: None,
            message: format!("cannot read: {e}"),
        })?;
        Self::parse(&String::from_utf8_lossy(&bytes), &path.display().to_string())
    }

    /// Parses LM-63 text; `label` names the source in errors (`lamp.ies:12: …`).
    pub fn parse(text: &str, label: &str) -> Result<Self, IesError> {
        let err = |line: Option<usize>, message: String| IesError { file: label.to_string(), line, message };
        // A byte-order mark would hide the format line (and misread a 2019 file as 1986's).
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let lines: Vec<(usize, &str)> = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())).collect();
        let first = lines.iter().find(|(_, l)| !l.is_empty()).map_or("", |(_, l)| *l);
        let upper = first.to_ascii_uppercase();
        let format = if upper.starts_with("IESNA:LM-63-1995") {
            IesFormat::Lm63_1995
        } else if upper.starts_with("IESNA:LM-63-2002") {
            IesFormat::Lm63_2002
        } else if upper.starts_with("IES:LM-63-") {
            IesFormat::Lm63_2019
        } else if upper.starts_with("IESNA91") {
            IesFormat::Lm63_1991
        } else if upper.starts_with("IESNA") {
            return Err(err(Some(1), format!("unknown format line \"{first}\"")));
        } else {
            IesFormat::Lm63_1986
        };
        let tilt_at = lines
            .iter()
            .position(|(_, l)| l.to_ascii_uppercase().starts_with("TILT"))
            .ok_or_else(|| err(None, "no TILT= line: this is not an IES LM-63 file".into()))?;
        let mut keywords = Vec::new();
        for &(_, line) in &lines[..tilt_at] {
            if let Some(rest) = line.strip_prefix('[')
                && let Some((key, value)) = rest.split_once(']')
            {
                let key = key.trim().to_string();
                // `[MORE]` continues the previous keyword's text.
                match keywords.last_mut() {
                    Some((_, v)) if key == "MORE" => {
                        let v: &mut String = v;
                        v.push(' ');
                        v.push_str(value.trim());
                    }
                    _ => keywords.push((key, value.trim().to_string())),
                }
            }
        }
        let (tilt_line, tilt_text) = lines[tilt_at];
        let tilt_value = tilt_text.split_once('=').map(|(_, v)| v.trim()).ok_or_else(|| {
            err(Some(tilt_line), format!("expected TILT=NONE, TILT=INCLUDE or TILT=<file>, found \"{tilt_text}\""))
        })?;
        let mut n = Numbers::new(&lines[tilt_at + 1..], label);
        let tilt = match tilt_value.to_ascii_uppercase().as_str() {
            "NONE" => Tilt::None,
            "INCLUDE" => {
                let geometry = n.count("the lamp-to-luminaire geometry", 3)? as u32;
                let pairs = n.count("the number of tilt angles", MAX_ANGLES)?;
                let angles = n.list(pairs, "tilt angles")?;
                let factors = n.list(pairs, "tilt factors")?;
                Tilt::Included { geometry, angles, factors }
            }
            _ => {
                tracing::warn!("{label}: tilt data in {tilt_value} is not read; the profile is used as measured");
                Tilt::File(tilt_value.to_string())
            }
        };
        let _lamps = n.number("the number of lamps")?;
        let _lumens_per_lamp = n.number("lumens per lamp")?;
        let multiplier = n.number("the candela multiplier")?;
        let nv_line = n.line();
        let nv = n.count("the number of vertical angles", MAX_ANGLES)?;
        let nh = n.count("the number of horizontal angles", MAX_ANGLES)?;
        if nv < 2 || nh < 1 {
            return Err(err(nv_line, format!("{nv} vertical and {nh} horizontal angles: need at least 2 and 1")));
        }
        if nv * nh > MAX_VALUES {
            return Err(err(nv_line, format!("{nv} × {nh} candela values; at most {MAX_VALUES} are accepted")));
        }
        let type_line = n.line();
        let photometric_type = n.count("the photometric type", 3)?;
        match photometric_type {
            1 => {}
            2 | 3 => {
                let t = if photometric_type == 2 { "B" } else { "A" };
                return Err(err(
                    type_line,
                    format!("type {t} photometry is not supported (only type C, photometric type 1)"),
                ));
            }
            other => return Err(err(type_line, format!("photometric type {other}: must be 1, 2 or 3"))),
        }
        let units_line = n.line();
        let units = n.count("the units type", 2)?;
        let to_metres = match units {
            1 => 0.3048,
            2 => 1.0,
            other => return Err(err(units_line, format!("units type {other}: must be 1 (feet) or 2 (metres)"))),
        };
        let width = n.number("the luminous opening's width")?;
        let length = n.number("the luminous opening's length")?;
        let height = n.number("the luminous opening's height")?;
        let ballast_factor = n.number("the ballast factor")?;
        // Before 1995 this was the ballast-lamp photometric factor; since, "future use" (1995)
        // or the file generation type (2019), neither of which scales the values.
        let second_factor = n.number("the ballast-lamp factor or file generation type")?;
        let input_watts = n.number("input watts")?;
        let scale = multiplier
            * ballast_factor
            * if matches!(format, IesFormat::Lm63_1986 | IesFormat::Lm63_1991) { second_factor } else { 1.0 };
        if scale < 0.0 {
            return Err(err(None, format!("candela multiplier × ballast factor is {scale}: must be ≥ 0")));
        }
        let v_line = n.line();
        let vertical_angles = n.list(nv, "vertical angles")?;
        let h_line = n.line();
        let horizontal_angles = n.list(nh, "horizontal angles")?;
        let raw = n.list(nv * nh, "candela values")?;
        if n.remaining() > 0 {
            tracing::warn!("{label}: {} numbers after the candela values are ignored", n.remaining());
        }

        check_ascending(&vertical_angles, 0.0, 180.0, "vertical").map_err(|m| err(v_line, m))?;
        check_ascending(&horizontal_angles, 0.0, 360.0, "horizontal").map_err(|m| err(h_line, m))?;
        let (h0, h1) = (horizontal_angles[0], horizontal_angles[nh - 1]);
        let symmetry = if nh == 1 {
            Symmetry::Axial
        } else if h0 == 0.0 && h1 == 90.0 {
            Symmetry::Quadrant
        } else if h0 == 0.0 && h1 == 180.0 {
            Symmetry::Bilateral0To180
        } else if h0 == 90.0 && h1 == 270.0 {
            Symmetry::Bilateral90To270
        } else if h0 == 0.0 {
            Symmetry::None
        } else {
            return Err(err(
                h_line,
                format!("horizontal angles {h0}°–{h1}°: type C files start at 0° (or run 90°–270°)"),
            ));
        };
        let negative = raw.iter().filter(|v| **v < 0.0).count();
        if negative > 0 {
            tracing::warn!("{label}: {negative} negative candela values read as 0");
        }
        let candela = raw.iter().map(|v| (v * scale).max(0.0)).collect();
        let mut profile = IesProfile {
            label: label.to_string(),
            format,
            keywords,
            tilt,
            vertical_angles,
            horizontal_angles,
            candela,
            symmetry,
            opening: [width * to_metres, length * to_metres, height * to_metres],
            input_watts,
            grid: ProfileGrid { rows: 0, columns: 0, peak: 0.0, values: Vec::new() },
        };
        profile.grid = profile.resample();
        Ok(profile)
    }

    /// The grid the renderer samples.
    pub fn grid(&self) -> &ProfileGrid {
        &self.grid
    }

    /// Candela toward vertical angle `gamma` and horizontal angle `c` (degrees), interpolated
    /// bilinearly between the file's samples as LM-63 intends, with its symmetry applied.
    pub fn candela_at(&self, gamma: f32, c: f32) -> f32 {
        let v = &self.vertical_angles;
        if !(v[0]..=v[v.len() - 1]).contains(&gamma) {
            return 0.0;
        }
        let c = c.rem_euclid(360.0);
        let c = match self.symmetry {
            Symmetry::Axial => 0.0,
            Symmetry::Quadrant => {
                let c = c % 180.0;
                if c > 90.0 { 180.0 - c } else { c }
            }
            Symmetry::Bilateral0To180 => {
                if c > 180.0 {
                    360.0 - c
                } else {
                    c
                }
            }
            Symmetry::Bilateral90To270 => {
                if c < 90.0 {
                    180.0 - c
                } else if c > 270.0 {
                    540.0 - c
                } else {
                    c
                }
            }
            Symmetry::None => c,
        };
        let (vi, vt) = bracket(v, gamma);
        let h = &self.horizontal_angles;
        let nv = v.len();
        let at = |hi: usize, vi: usize| self.candela[hi * nv + vi];
        let along = |hi: usize| at(hi, vi) + (at(hi, (vi + 1).min(nv - 1)) - at(hi, vi)) * vt;
        if h.len() == 1 {
            return along(0);
        }
        let last = h[h.len() - 1];
        if c > last {
            // Only without symmetry: wrap from the last plane back to the first (at 360°).
            let t = (c - last) / (360.0 - last);
            return along(h.len() - 1) + (along(0) - along(h.len() - 1)) * t;
        }
        let (hi, ht) = bracket(h, c);
        along(hi) + (along((hi + 1).min(h.len() - 1)) - along(hi)) * ht
    }

    fn resample(&self) -> ProfileGrid {
        let v_step = grid_step(&self.vertical_angles);
        let rows = (180.0 / v_step).round() as u32 + 1;
        let columns = if self.symmetry == Symmetry::Axial {
            1
        } else {
            (360.0 / grid_step(&self.horizontal_angles)).round() as u32
        };
        let c_step = 360.0 / columns as f32;
        let mut values = Vec::with_capacity((rows * columns) as usize);
        for col in 0..columns {
            for row in 0..rows {
                values.push(self.candela_at(row as f32 * v_step, col as f32 * c_step));
            }
        }
        let peak = self.candela.iter().fold(0.0f32, |a, &b| a.max(b));
        if peak > 0.0 {
            for v in &mut values {
                *v /= peak;
            }
        }
        ProfileGrid { rows, columns, peak, values }
    }
}

/// The index of the sample at or below `x` in ascending `xs` and the fraction toward the next.
fn bracket(xs: &[f32], x: f32) -> (usize, f32) {
    let i = xs.partition_point(|&a| a <= x).saturating_sub(1).min(xs.len() - 1);
    match xs.get(i + 1) {
        Some(&next) if next > xs[i] => (i, ((x - xs[i]) / (next - xs[i])).clamp(0.0, 1.0)),
        _ => (i, 0.0),
    }
}

fn check_ascending(angles: &[f32], lo: f32, hi: f32, what: &str) -> Result<(), String> {
    if let Some(a) = angles.iter().find(|a| !(lo..=hi).contains(*a)) {
        return Err(format!("{what} angle {a}° is outside {lo}°–{hi}°"));
    }
    if let Some(w) = angles.windows(2).find(|w| w[1] < w[0]) {
        return Err(format!("{what} angles must ascend, but {}° follows {}°", w[1], w[0]));
    }
    Ok(())
}

/// The coarsest listed step that every angle is a whole multiple of.
fn grid_step(angles: &[f32]) -> f32 {
    GRID_STEPS
        .iter()
        .copied()
        .find(|&s| angles.iter().all(|a| (a / s - (a / s).round()).abs() < 1e-4))
        .unwrap_or(FINEST_STEP)
}

/// Editing derives nothing else from the asset.
impl crate::assets::AssetEdit for IesProfile {}

#[cfg(test)]
mod tests {
    use super::*;

    /// A type C profile with the given angles and values, in the 2002 format.
    fn profile_text(vertical: &[f32], horizontal: &[f32], candela: &[f32], multiplier: f32) -> String {
        let join = |xs: &[f32]| xs.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" ");
        format!(
            "IESNA:LM-63-2002\n[TEST] synthetic\n[MANUFAC] Penumbra\nTILT=NONE\n1 -1 {multiplier} {} {} 1 2 0.1 0.1 0\n1.0 1 20\n{}\n{}\n{}\n",
            vertical.len(),
            horizontal.len(),
            join(vertical),
            join(horizontal),
            join(candela)
        )
    }

    #[test]
    fn reads_a_2002_file_with_keywords_and_multiplier() {
        let text = profile_text(&[0.0, 45.0, 90.0], &[0.0], &[100.0, 50.0, 0.0], 2.0);
        let p = IesProfile::parse(&text, "t.ies").unwrap();
        assert_eq!(p.format, IesFormat::Lm63_2002);
        assert_eq!(p.keywords[1], ("MANUFAC".to_string(), "Penumbra".to_string()));
        assert_eq!(p.candela, vec![200.0, 100.0, 0.0]);
        assert_eq!(p.symmetry, Symmetry::Axial);
        assert_eq!(p.candela_at(22.5, 123.0), 150.0);
        assert_eq!(p.candela_at(100.0, 0.0), 0.0, "beyond the last vertical angle");
        assert_eq!(p.opening, [0.1, 0.1, 0.0]);
    }

    #[test]
    fn numbers_may_be_split_by_commas_and_lines_anywhere() {
        let text = "IESNA91\nTILT=NONE\n1,-1,1\n2\n1 1 2 0 0 0 1 1 10\n0\n90 0 10,\n5\n";
        let p = IesProfile::parse(text, "t.ies").unwrap();
        assert_eq!(p.format, IesFormat::Lm63_1991);
        assert_eq!(p.candela, vec![10.0, 5.0]);
    }

    #[test]
    fn the_1986_format_has_no_format_line_and_scales_by_both_factors() {
        let text = "Some lamp\nTILT=NONE\n1 1000 1 2 1 1 1 0 0 0\n0.5 0.5 10\n0 90\n0\n100 100\n";
        let p = IesProfile::parse(text, "old.ies").unwrap();
        assert_eq!(p.format, IesFormat::Lm63_1986);
        assert_eq!(p.candela, vec![25.0, 25.0]);
        let text = "IES:LM-63-2019\nTILT=NONE\n1 1000 1 2 1 1 1 0 0 0\n0.5 1.1 10\n0 90\n0\n100 100\n";
        assert_eq!(IesProfile::parse(text, "new.ies").unwrap().candela, vec![50.0, 50.0]);
        // The same after a UTF-8 byte-order mark: still 2019's (the 1.1 is the file generation
        // type, not a factor).
        let p = IesProfile::parse(&format!("\u{feff}{text}"), "bom.ies").unwrap();
        assert_eq!((p.format, p.candela), (IesFormat::Lm63_2019, vec![50.0, 50.0]));
    }

    #[test]
    fn included_tilt_data_is_read_past() {
        let text =
            "IESNA:LM-63-1995\nTILT=INCLUDE\n1\n3\n0 45 90\n1 0.9 0.8\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n7 3\n";
        let p = IesProfile::parse(text, "t.ies").unwrap();
        assert_eq!(p.tilt, Tilt::Included { geometry: 1, angles: vec![0.0, 45.0, 90.0], factors: vec![1.0, 0.9, 0.8] });
        assert_eq!(p.candela, vec![7.0, 3.0]);
    }

    #[test]
    fn horizontal_symmetries_fill_the_whole_turn() {
        let v = [0.0, 90.0];
        // Quadrant: 0–90, values rising with C.
        let q = IesProfile::parse(&profile_text(&v, &[0.0, 90.0], &[10.0, 10.0, 20.0, 20.0], 1.0), "q").unwrap();
        assert_eq!(q.symmetry, Symmetry::Quadrant);
        for (c, want) in [(45.0, 15.0), (135.0, 15.0), (180.0, 10.0), (270.0, 20.0), (315.0, 15.0)] {
            assert_eq!(q.candela_at(0.0, c), want, "C = {c}");
        }
        let b = IesProfile::parse(&profile_text(&v, &[0.0, 180.0], &[10.0, 10.0, 30.0, 30.0], 1.0), "b").unwrap();
        assert_eq!(b.symmetry, Symmetry::Bilateral0To180);
        assert_eq!(b.candela_at(0.0, 270.0), 20.0);
        assert_eq!(b.candela_at(0.0, 315.0), 15.0);
        let b = IesProfile::parse(&profile_text(&v, &[90.0, 270.0], &[10.0, 10.0, 30.0, 30.0], 1.0), "b").unwrap();
        assert_eq!(b.symmetry, Symmetry::Bilateral90To270);
        assert_eq!(b.candela_at(0.0, 0.0), 20.0);
        assert_eq!(b.candela_at(0.0, 45.0), 15.0, "mirror of 135°");
        assert_eq!(b.candela_at(0.0, 315.0), 25.0, "mirror of 225°");
        // No symmetry, and no 360° plane: wraps from 270° back to 0°.
        let f = IesProfile::parse(
            &profile_text(&v, &[0.0, 90.0, 180.0, 270.0], &[0.0, 0.0, 10.0, 10.0, 20.0, 20.0, 30.0, 30.0], 1.0),
            "f",
        )
        .unwrap();
        assert_eq!(f.symmetry, Symmetry::None);
        assert_eq!(f.candela_at(0.0, 315.0), 15.0);
        assert_eq!(f.candela_at(0.0, -45.0), 15.0);
    }

    #[test]
    fn the_grid_holds_the_files_own_samples() {
        let v: Vec<f32> = (0..=36).map(|i| i as f32 * 2.5).collect();
        let h: Vec<f32> = (0..=16).map(|i| i as f32 * 22.5).collect();
        let candela: Vec<f32> = (0..h.len() * v.len()).map(|i| ((i * 7919) % 1000) as f32).collect();
        let p = IesProfile::parse(&profile_text(&v, &h, &candela, 1.0), "grid.ies").unwrap();
        let g = p.grid();
        assert_eq!((g.rows, g.columns), (73, 16), "2.5° rows over 0–180°, 22.5° planes");
        for (hi, &c) in h[..16].iter().enumerate() {
            for (vi, &gamma) in v.iter().enumerate() {
                let got = g.values[hi * g.rows as usize + (gamma / 2.5).round() as usize] * g.peak;
                let want = p.candela[hi * v.len() + vi];
                assert!((got - want).abs() <= 1e-3 * g.peak, "γ {gamma} C {c}: {got} vs {want}");
            }
        }
        // Past 90° (the file's last vertical angle) the grid is dark.
        assert!(g.values[40..73].iter().all(|&x| x == 0.0));
        // Irregular angles fall back to the finest step.
        let p = IesProfile::parse(&profile_text(&[0.0, 33.3, 90.0], &[0.0], &[1.0, 2.0, 3.0], 1.0), "odd").unwrap();
        assert_eq!((p.grid().rows, p.grid().columns), (721, 1));
    }

    #[test]
    fn bad_files_name_the_file_the_line_and_the_problem() {
        let cases: &[(&str, &str)] = &[
            ("", "no TILT= line"),
            (
                "IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 0\n0 45 90\n0\n1 2\n",
                "ends after 2 of the 3 candela values",
            ),
            (
                "IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n1 x\n",
                ":7: expected candela values #2, found \"x\"",
            ),
            ("IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n1 NaN\n", "not a finite number"),
            (
                "IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 2 1 2 2 0 0 0\n1 1 0\n0 90\n0\n1 1\n",
                "type B photometry is not supported",
            ),
            (
                "IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n90 0\n0\n1 1\n",
                ":5: vertical angles must ascend",
            ),
            ("IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 190\n0\n1 1\n", "outside 0°–180°"),
            ("IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 2 2 1 2 0 0 0\n1 1 0\n0 90\n45 90\n1 1 1 1\n", "start at 0°"),
            ("IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 5000 5000 1 2 0 0 0\n", "at most 1048576"),
            ("IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 99999 1 1 2 0 0 0\n", "at most 10000 are accepted"),
            ("IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 2.5 1 1 2 0 0 0\n", "whole number"),
            ("IESNA:LM-63-1995\nTILT=NONE\n1 -1 1 1 1 1 2 0 0 0\n1 1 0\n0\n0\n1\n", "need at least 2"),
            ("IESNA:LM-63-1995\nTILT=NONE\n1 -1 -1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n1 1\n", "must be ≥ 0"),
            ("IESNA:LM-63-1995\nTILT NONE\n", "expected TILT=NONE"),
            ("IESNA:LM-63-2050X\nTILT=NONE\n", "unknown format line"),
        ];
        for (text, want) in cases {
            let msg = IesProfile::parse(text, "bad.ies").expect_err(text).to_string();
            assert!(msg.starts_with("bad.ies"), "{msg}");
            assert!(msg.contains(want), "{msg:?} should say {want:?}");
        }
        let e = IesProfile::load(Path::new("/nonexistent/lamp.ies")).unwrap_err();
        assert!(e.to_string().starts_with("/nonexistent/lamp.ies: cannot read"), "{e}");
    }

    #[test]
    fn negative_candela_reads_as_zero() {
        let p = IesProfile::parse(&profile_text(&[0.0, 90.0], &[0.0], &[-1.0, 4.0], 1.0), "n").unwrap();
        assert_eq!(p.candela, vec![0.0, 4.0]);
        assert_eq!(p.grid().peak, 4.0);
    }
}
