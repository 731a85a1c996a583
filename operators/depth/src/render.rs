//! Colour-mapped images of the metric maps, each with a legend strip drawn below the image.
//!
//! No font files are needed: legend labels use a built-in 3×5 pixel font (digits, capitals and a
//! few signs) drawn at twice its size. Every image comes with a [`MapLegend`] stating its colour
//! mapping in words and numbers, which the JSON report carries, so the images can be read
//! without guessing.

use std::path::Path;

use crate::Result;
use crate::accuracy::{AccuracyMap, AccuracyParams, Zone};
use crate::edge::EdgeClass;
use crate::frame::{HEIGHT, PIXELS, WIDTH};
use crate::io::write_rgb_png;
use crate::sequence::{MetricsParams, SequenceMaps};

/// Height of the legend strip below each map, pixels.
pub const LEGEND_HEIGHT: usize = 30;

/// Height of the title strip [`with_title`] puts above a map, pixels.
pub const TITLE_HEIGHT: usize = 20;

/// An 8-bit RGB image.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Row-major RGB bytes.
    pub rgb: Vec<u8>,
}

impl Image {
    /// A filled image.
    #[must_use]
    pub fn new(width: usize, height: usize, fill: [u8; 3]) -> Self {
        Self {
            width,
            height,
            rgb: fill
                .iter()
                .copied()
                .cycle()
                .take(3 * width * height)
                .collect(),
        }
    }

    /// Colour at (x, y).
    #[must_use]
    pub fn get(&self, x: usize, y: usize) -> [u8; 3] {
        let i = 3 * (y * self.width + x);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// Sets (x, y) if inside the image.
    pub fn set(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = 3 * (y * self.width + x);
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    /// Fills a rectangle (clipped).
    pub fn fill(&mut self, x: usize, y: usize, w: usize, h: usize, c: [u8; 3]) {
        for yy in y..y + h {
            for xx in x..x + w {
                self.set(xx, yy, c);
            }
        }
    }

    /// Draws `text` with the built-in font at `scale`; returns the x after the last glyph.
    pub fn text(&mut self, x: usize, y: usize, text: &str, scale: usize, c: [u8; 3]) -> usize {
        let mut cx = x;
        for ch in text.chars() {
            let rows = glyph(ch);
            for (r, bits) in rows.iter().enumerate() {
                for col in 0..3 {
                    if bits & (0b100 >> col) != 0 {
                        self.fill(cx + col * scale, y + r * scale, scale, scale, c);
                    }
                }
            }
            cx += 4 * scale;
        }
        cx
    }

    /// Writes the image as an RGB PNG.
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn write_png(&self, path: &Path) -> Result<()> {
        write_rgb_png(path, self.width, self.height, &self.rgb)
    }
}

/// The 3×5 glyph of `ch` (rows top to bottom, bit 2 = left column); unknown characters draw
/// as a hollow box.
fn glyph(ch: char) -> [u8; 5] {
    match ch.to_ascii_uppercase() {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 2, 2],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '.' => [0, 0, 0, 0, 2],
        '-' => [0, 0, 7, 0, 0],
        '+' => [0, 2, 7, 2, 0],
        '<' => [1, 2, 4, 2, 1],
        '>' => [4, 2, 1, 2, 4],
        '/' => [1, 1, 2, 4, 4],
        ' ' => [0; 5],
        ':' => [0, 2, 0, 2, 0],
        '_' => [0, 0, 0, 0, 7],
        ',' => [0, 0, 0, 2, 4],
        '(' => [1, 2, 2, 2, 1],
        ')' => [4, 2, 2, 2, 4],
        'A' => [2, 5, 7, 5, 5],
        'B' => [6, 5, 6, 5, 6],
        'C' => [3, 4, 4, 4, 3],
        'D' => [6, 5, 5, 5, 6],
        'E' => [7, 4, 6, 4, 7],
        'F' => [7, 4, 6, 4, 4],
        'G' => [3, 4, 5, 5, 3],
        'H' => [5, 5, 7, 5, 5],
        'I' => [7, 2, 2, 2, 7],
        'J' => [1, 1, 1, 5, 2],
        'K' => [5, 5, 6, 5, 5],
        'L' => [4, 4, 4, 4, 7],
        'M' => [5, 7, 7, 5, 5],
        'N' => [6, 5, 5, 5, 5],
        'O' => [2, 5, 5, 5, 2],
        'P' => [6, 5, 6, 4, 4],
        'Q' => [2, 5, 5, 6, 3],
        'R' => [6, 5, 6, 5, 5],
        'S' => [3, 4, 2, 1, 6],
        'T' => [7, 2, 2, 2, 2],
        'U' => [5, 5, 5, 5, 7],
        'V' => [5, 5, 5, 5, 2],
        'W' => [5, 5, 7, 7, 5],
        'X' => [5, 5, 2, 5, 5],
        'Y' => [5, 5, 2, 2, 2],
        'Z' => [7, 1, 2, 4, 7],
        _ => [7, 5, 5, 5, 7],
    }
}

/// One colour of a legend and what it means.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LegendEntry {
    /// The colour.
    pub rgb: [u8; 3],
    /// Its meaning.
    pub meaning: String,
}

/// A continuous colour scale.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ColourScale {
    /// Name of the colour map.
    pub colormap: &'static str,
    /// Value at the left end of the legend bar (and below).
    pub min: f64,
    /// Value at the right end of the legend bar (and above).
    pub max: f64,
    /// Unit of the values.
    pub unit: &'static str,
}

/// How to read one image: its colours (discrete entries and/or a continuous scale).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MapLegend {
    /// File stem of the image (`<name>.png`).
    pub name: &'static str,
    /// Its title: what is mapped and in which unit, in the capitals the built-in font draws
    /// (`MEAN DEPTH (M)`); [`with_title`] draws it above the map with the sensor's name.
    pub title: &'static str,
    /// What the image shows.
    pub shows: &'static str,
    /// Discrete colours.
    pub entries: Vec<LegendEntry>,
    /// Continuous scale, if any.
    pub scale: Option<ColourScale>,
    /// Where the legend is drawn.
    pub legend_strip: &'static str,
}

const NO_DATA: [u8; 3] = [0, 0, 0];
const WHITE: [u8; 3] = [255, 255, 255];
const LEGEND_BG: [u8; 3] = [24, 24, 24];
const GREEN: [u8; 3] = [0, 170, 60];
const YELLOW: [u8; 3] = [240, 200, 0];
const RED: [u8; 3] = [215, 30, 30];
const OFF_TARGET: [u8; 3] = [70, 70, 70];
const OUTSIDE_CONE: [u8; 3] = [30, 30, 46];

fn lerp(a: [u8; 3], b: [u8; 3], t: f64) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0);
    std::array::from_fn(|k| {
        (f64::from(a[k]) + (f64::from(b[k]) - f64::from(a[k])) * t).round() as u8
    })
}

/// Viridis, approximated by five anchors (perceptually ordered dark blue → yellow).
#[must_use]
pub fn viridis(t: f64) -> [u8; 3] {
    const ANCHORS: [[u8; 3]; 5] = [
        [68, 1, 84],
        [59, 82, 139],
        [33, 145, 140],
        [94, 201, 98],
        [253, 231, 37],
    ];
    let t = t.clamp(0.0, 1.0) * 4.0;
    let i = (t.floor() as usize).min(3);
    lerp(ANCHORS[i], ANCHORS[i + 1], t - i as f64)
}

/// Diverging blue → white → red for t in −1..=1.
#[must_use]
pub fn diverging(t: f64) -> [u8; 3] {
    if t < 0.0 {
        lerp(WHITE, [33, 102, 172], -t)
    } else {
        lerp(WHITE, [178, 24, 43], t)
    }
}

/// `image` with a title strip above it: `title` in white capitals, cut at the image's width.
/// The map and its legend are unchanged below the strip.
#[must_use]
pub fn with_title(image: &Image, title: &str) -> Image {
    let mut out = Image::new(image.width, image.height + TITLE_HEIGHT, LEGEND_BG);
    out.rgb[3 * image.width * TITLE_HEIGHT..].copy_from_slice(&image.rgb);
    let fits = image.width.saturating_sub(12) / 8;
    let text: String = title.to_ascii_uppercase().chars().take(fits).collect();
    out.text(6, 5, &text, 2, WHITE);
    out
}

fn canvas() -> Image {
    let mut img = Image::new(WIDTH, HEIGHT + LEGEND_HEIGHT, NO_DATA);
    img.fill(0, HEIGHT, WIDTH, LEGEND_HEIGHT, LEGEND_BG);
    img
}

fn swatches(img: &mut Image, entries: &[(&[u8; 3], &str)]) {
    let mut x = 6;
    let y = HEIGHT + 8;
    for (c, label) in entries {
        img.fill(x, y, 14, 14, **c);
        x = img.text(x + 18, y + 2, label, 2, WHITE) + 10;
    }
}

fn bar(img: &mut Image, map: impl Fn(f64) -> [u8; 3], left: &str, right: &str, unit: &str) {
    let y = HEIGHT + 8;
    let x0 = 6 + left.len() * 8 + 6;
    let x1 = WIDTH - 6 - (right.len() + unit.len() + 1) * 8 - 6;
    img.text(6, y + 2, left, 2, WHITE);
    for x in x0..x1 {
        let c = map((x - x0) as f64 / (x1 - x0 - 1) as f64);
        img.fill(x, y, 1, 14, c);
    }
    img.text(x1 + 6, y + 2, &format!("{right} {unit}"), 2, WHITE);
}

fn fmt_value(v: f64) -> String {
    if v.abs() >= 10.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.1}")
    }
}

/// Accuracy zones (§5.1.1): green/yellow/red per pixel on the target, dimmed outside the
/// elliptical cone, whose outline is drawn in white.
#[must_use]
pub fn render_accuracy(map: &AccuracyMap, params: &AccuracyParams) -> (Image, MapLegend) {
    let mut img = canvas();
    for i in 0..PIXELS {
        let c = match map.zones[i] {
            Some(Zone::Green) => GREEN,
            Some(Zone::Yellow) => YELLOW,
            Some(Zone::Red) => RED,
            None => OFF_TARGET,
        };
        let c = if map.in_cone[i] { c } else { OUTSIDE_CONE };
        img.set(i % WIDTH, i / WIDTH, c);
    }
    for i in 0..PIXELS {
        let (x, y) = (i % WIDTH, i / WIDTH);
        let edge = map.in_cone[i]
            && [(-1, 0), (1, 0), (0, -1), (0, 1)]
                .iter()
                .any(|&(dx, dy): &(isize, isize)| {
                    let (nx, ny) = (x as isize + dx, y as isize + dy);
                    nx >= 0
                        && ny >= 0
                        && (nx as usize) < WIDTH
                        && (ny as usize) < HEIGHT
                        && !map.in_cone[ny as usize * WIDTH + nx as usize]
                });
        if edge {
            img.set(x, y, WHITE);
        }
    }
    let g = format!("<{}", fmt_value(params.green_below_mm));
    let yl = format!(
        "{}-{}",
        fmt_value(params.green_below_mm),
        fmt_value(params.yellow_below_mm)
    );
    let r = format!(">{} MM", fmt_value(params.yellow_below_mm));
    swatches(
        &mut img,
        &[
            (&GREEN, &g),
            (&YELLOW, &yl),
            (&RED, &r),
            (&OFF_TARGET, "OFF TARGET"),
            (&OUTSIDE_CONE, "OUTSIDE CONE"),
        ],
    );
    let legend = MapLegend {
        name: "accuracy_zones",
        title: "DEPTH ERROR ZONES (MM)",
        shows: "per-pixel |mean depth - true depth| zone (thesis 5.1.1) inside the 70x60 deg elliptical cone (white outline); pixels outside the cone are not classified",
        entries: vec![
            LegendEntry {
                rgb: GREEN,
                meaning: format!("green: error < {} mm", params.green_below_mm),
            },
            LegendEntry {
                rgb: YELLOW,
                meaning: format!(
                    "yellow: {}-{} mm",
                    params.green_below_mm, params.yellow_below_mm
                ),
            },
            LegendEntry {
                rgb: RED,
                meaning: format!("red: error > {} mm", params.yellow_below_mm),
            },
            LegendEntry {
                rgb: OFF_TARGET,
                meaning: "not on the target plane or no data".into(),
            },
            LegendEntry {
                rgb: OUTSIDE_CONE,
                meaning: "outside the elliptical cone: not classified".into(),
            },
            LegendEntry {
                rgb: WHITE,
                meaning: "outline of the elliptical cone".into(),
            },
        ],
        scale: None,
        legend_strip: "bottom 30 px: swatches green, yellow, red with their limits in mm, off target, outside the cone",
    };
    (img, legend)
}

fn percentile(mut v: Vec<f64>, q: f64) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let i = ((v.len() - 1) as f64 * q).round() as usize;
    v.get(i).copied()
}

/// Entropy map (§5.1.3, Fig. 5.4a), viridis from 0 bits to the 99th percentile.
#[must_use]
pub fn render_entropy(entropy: &[Option<f32>]) -> (Image, MapLegend) {
    let values: Vec<f64> = entropy.iter().flatten().map(|&h| f64::from(h)).collect();
    let max = percentile(values, 0.99).unwrap_or(1.0).max(0.5);
    let max = (max * 10.0).ceil() / 10.0;
    let mut img = canvas();
    for (i, h) in entropy.iter().enumerate().take(PIXELS) {
        if let Some(h) = h {
            img.set(i % WIDTH, i / WIDTH, viridis(f64::from(*h) / max));
        }
    }
    bar(&mut img, viridis, "0", &fmt_value(max), "BITS");
    let legend = MapLegend {
        name: "entropy",
        title: "DEPTH ENTROPY (BITS)",
        shows: "per-pixel entropy of frame-to-frame depth differences, eq. 3.3",
        entries: vec![LegendEntry {
            rgb: NO_DATA,
            meaning: "no valid frame pair".into(),
        }],
        scale: Some(ColourScale {
            colormap: "viridis",
            min: 0.0,
            max,
            unit: "bits",
        }),
        legend_strip: "bottom 30 px: colour bar from min (left) to max (right)",
    };
    (img, legend)
}

const RIM: [u8; 3] = [0, 220, 255];
const BAND: [u8; 3] = [255, 40, 40];
const FLYING: [u8; 3] = [255, 0, 255];
const BG_EDGE: [u8; 3] = [255, 160, 0];

/// Edge band (§5.1.4, Fig. 5.5): depth in grey (near = bright), object rim cyan, no-data band
/// red, flying pixels magenta, the background pixels nearest the rim orange.
#[must_use]
pub fn render_edge(classes: &[EdgeClass], depth_mm: &[u16]) -> (Image, MapLegend) {
    let mut img = canvas();
    for i in 0..PIXELS.min(classes.len()).min(depth_mm.len()) {
        let z = depth_mm[i];
        let grey = if z == 0 {
            NO_DATA
        } else {
            let t = 1.0 - ((f64::from(z) - 500.0) / 4000.0).clamp(0.0, 1.0);
            let g = (60.0 + 150.0 * t) as u8;
            [g, g, g]
        };
        let c = match classes[i] {
            EdgeClass::Other => grey,
            EdgeClass::Rim => RIM,
            EdgeClass::BandZero => BAND,
            EdgeClass::Flying => FLYING,
            EdgeClass::Background => BG_EDGE,
        };
        img.set(i % WIDTH, i / WIDTH, c);
    }
    swatches(
        &mut img,
        &[
            (&RIM, "OBJECT RIM"),
            (&BAND, "NO DATA"),
            (&FLYING, "FLYING"),
            (&BG_EDGE, "BACKGROUND"),
        ],
    );
    let legend = MapLegend {
        name: "edge_band",
        title: "EDGE NOISE (DEPTH IN GREY, 0.5-4.5 M)",
        shows: "edge noise (thesis 3.4): depth in grey 0.5 m (bright) to 4.5 m (dark), black = no data",
        entries: vec![
            LegendEntry {
                rgb: RIM,
                meaning: "object rim pixel".into(),
            },
            LegendEntry {
                rgb: BAND,
                meaning: "no-data pixel on the band between rim and background".into(),
            },
            LegendEntry {
                rgb: FLYING,
                meaning: "flying pixel (between a nearer and a farther surface)".into(),
            },
            LegendEntry {
                rgb: BG_EDGE,
                meaning: "background pixel nearest to a rim pixel".into(),
            },
            LegendEntry {
                rgb: NO_DATA,
                meaning: "no data elsewhere".into(),
            },
        ],
        scale: None,
        legend_strip: "bottom 30 px: swatches object rim, no data (the band next to the rim), flying pixel, background next to the rim",
    };
    (img, legend)
}

/// Structural residual (§5.1.5, Fig. 5.6): measured − fitted plane, diverging blue (nearer) →
/// white → red (farther), symmetric about 0 at the 99th percentile of |residual|.
#[must_use]
pub fn render_residual(residual_mm: &[f32]) -> (Image, MapLegend) {
    let values: Vec<f64> = residual_mm
        .iter()
        .filter(|v| v.is_finite())
        .map(|&v| f64::from(v).abs())
        .collect();
    let range = percentile(values, 0.99).unwrap_or(1.0).max(0.5);
    let range = (range * 10.0).ceil() / 10.0;
    let mut img = canvas();
    for (i, &r) in residual_mm.iter().enumerate().take(PIXELS) {
        if r.is_finite() {
            img.set(i % WIDTH, i / WIDTH, diverging(f64::from(r) / range));
        }
    }
    bar(
        &mut img,
        |t| diverging(2.0 * t - 1.0),
        &format!("-{}", fmt_value(range)),
        &format!("+{}", fmt_value(range)),
        "MM",
    );
    let legend = MapLegend {
        name: "structural_residual",
        title: "STRUCTURAL NOISE: DEPTH MINUS PLANE (MM)",
        shows: "structural noise (thesis 3.5): mean depth minus fitted plane; black = off the plane or no data",
        entries: vec![LegendEntry {
            rgb: NO_DATA,
            meaning: "off the plane or no data".into(),
        }],
        scale: Some(ColourScale {
            colormap: "blue-white-red",
            min: -range,
            max: range,
            unit: "mm",
        }),
        legend_strip: "bottom 30 px: colour bar from min (left, blue) through 0 (white) to max (right, red)",
    };
    (img, legend)
}

/// Mean depth, viridis from 0.5 m (dark) to 4.5 m (yellow).
#[must_use]
pub fn render_depth(mean_mm: &[f32]) -> (Image, MapLegend) {
    let mut img = canvas();
    for (i, &z) in mean_mm.iter().enumerate().take(PIXELS) {
        if z.is_finite() && z > 0.0 {
            img.set(
                i % WIDTH,
                i / WIDTH,
                viridis((f64::from(z) - 500.0) / 4000.0),
            );
        }
    }
    bar(&mut img, viridis, "0.5", "4.5", "M");
    let legend = MapLegend {
        name: "depth",
        title: "MEAN DEPTH (M)",
        shows: "mean depth over the frames",
        entries: vec![LegendEntry {
            rgb: NO_DATA,
            meaning: "no data".into(),
        }],
        scale: Some(ColourScale {
            colormap: "viridis",
            min: 0.5,
            max: 4.5,
            unit: "m",
        }),
        legend_strip: "bottom 30 px: colour bar from min (left) to max (right)",
    };
    (img, legend)
}

/// Every map of a sequence: depth, accuracy zones (when a target was found), entropy (when
/// there were two frames), edge band and structural residual (when a plane was found).
#[must_use]
pub fn render_all(maps: &SequenceMaps, params: &MetricsParams) -> Vec<(Image, MapLegend)> {
    let mut out = vec![render_depth(&maps.mean_depth_mm)];
    if let Some(acc) = &maps.accuracy {
        out.push(render_accuracy(acc, &params.accuracy));
    }
    if maps.entropy.iter().any(Option::is_some) {
        out.push(render_entropy(&maps.entropy));
    }
    if !maps.edge.is_empty() {
        out.push(render_edge(&maps.edge, &maps.edge_depth_mm));
    }
    if let Some(r) = &maps.structural_residual_mm {
        out.push(render_residual(r));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The font draws known pixels: '1' has its stem in the middle column and a full base.
    #[test]
    fn font_draws_glyphs() {
        let mut img = Image::new(8, 6, NO_DATA);
        let end = img.text(0, 0, "1", 1, WHITE);
        assert_eq!(end, 4);
        assert_eq!(img.get(1, 0), WHITE);
        assert_eq!(img.get(0, 0), NO_DATA);
        assert!((0..3).all(|x| img.get(x, 4) == WHITE));
    }

    /// A title strip goes above the map, which stays pixel for pixel as it was.
    #[test]
    fn title_strip_is_added_above_the_map() {
        let (img, legend) = render_depth(&vec![1000.0; PIXELS]);
        let titled = with_title(&img, &format!("k1: {}", legend.title));
        assert_eq!(titled.height, img.height + TITLE_HEIGHT);
        assert_eq!(&titled.rgb[3 * WIDTH * TITLE_HEIGHT..], &img.rgb[..]);
        let strip = &titled.rgb[..3 * WIDTH * TITLE_HEIGHT];
        assert!(strip.chunks(3).any(|c| c == WHITE), "no title text drawn");
    }

    /// Outside its cone the accuracy map shows one flat colour, not a dimmed zone.
    #[test]
    fn accuracy_map_is_masked_to_its_cone() {
        let map = AccuracyMap {
            zones: vec![Some(Zone::Green); PIXELS],
            in_cone: (0..PIXELS).map(|i| i % WIDTH > WIDTH / 2).collect(),
        };
        let (img, _) = render_accuracy(&map, &AccuracyParams::default());
        assert_eq!(img.get(10, HEIGHT / 2), OUTSIDE_CONE);
        assert_eq!(img.get(WIDTH - 10, HEIGHT / 2), GREEN);
    }

    /// Colour maps hit their anchors at the ends.
    #[test]
    fn colour_map_ends() {
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
        assert_eq!(diverging(0.0), WHITE);
        assert_eq!(diverging(-1.0), [33, 102, 172]);
    }
}
