//! PNG copies of the study's SVG plots, rendered by `resvg` (pure Rust) with the system's fonts
//! (Debian: `fonts-dejavu-core`, installed by `ci/install-deps.sh`).
use resvg::tiny_skia::{Pixmap, Transform};
use resvg::usvg::{fontdb, Options, Tree};
use std::sync::{Arc, OnceLock};

/// Pixels per SVG unit: 760 x 480 plots become 1520 x 960 images.
const SCALE: f32 = 2.0;

/// The system's fonts, loaded once per process.
fn fonts() -> Arc<fontdb::Database> {
    static DB: OnceLock<Arc<fontdb::Database>> = OnceLock::new();
    DB.get_or_init(|| {
        let mut db = fontdb::Database::new();
        db.load_system_fonts();
        // the plots ask for "sans-serif": map it to a face that is there
        let family = db
            .faces()
            .find(|f| {
                f.families
                    .iter()
                    .any(|(name, _)| name.contains("Sans") && !name.contains("Mono"))
            })
            .map(|face| face.families[0].0.clone());
        match family {
            Some(family) => db.set_sans_serif_family(family),
            None => eprintln!(
                "warning: no sans-serif system font: the PNG plots are drawn without text \
                 (Debian: apt-get install fonts-dejavu-core)"
            ),
        }
        Arc::new(db)
    })
    .clone()
}

/// True when a font for the plots' text was found (without one, PNGs are drawn without text).
#[cfg(test)]
fn has_fonts() -> bool {
    !fonts().is_empty()
}

/// Renders an SVG document to PNG bytes.
pub fn svg_to_png(svg: &str) -> Result<Vec<u8>, String> {
    let opt = Options {
        fontdb: fonts(),
        ..Options::default()
    };
    let tree = Tree::from_str(svg, &opt).map_err(|e| format!("SVG not understood: {e}"))?;
    let size = tree
        .size()
        .scale_by(SCALE)
        .ok_or("empty plot")?
        .to_int_size();
    let mut pixmap = Pixmap::new(size.width(), size.height()).ok_or("empty plot")?;
    pixmap.fill(resvg::tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        Transform::from_scale(SCALE, SCALE),
        &mut pixmap.as_mut(),
    );
    pixmap
        .encode_png()
        .map_err(|e| format!("PNG encoding: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::svg::{Plot, Series};

    #[test]
    fn a_plot_renders_to_a_png_of_twice_its_size_with_ink_in_it() {
        let plot = Plot {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![Series {
                name: "s".into(),
                points: vec![(0.0, 0.0), (1.0, 1.0), (2.0, 4.0)],
            }],
            log_x: false,
            log_y: false,
            markers: true,
        };
        assert!(
            has_fonts(),
            "no system font for the plots' text (fonts-dejavu-core)"
        );
        let png = svg_to_png(&plot.to_svg()).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        // IHDR: width and height, big-endian, at bytes 16..24
        let w = u32::from_be_bytes(png[16..20].try_into().unwrap());
        let h = u32::from_be_bytes(png[20..24].try_into().unwrap());
        assert_eq!((w, h), (1520, 960));
        // decode through resvg's own PNG reader: not all white
        let pix = Pixmap::decode_png(&png).unwrap();
        let dark = pix
            .pixels()
            .iter()
            .filter(|p| p.red() < 128 && p.alpha() == 255)
            .count();
        assert!(dark > 1000, "{dark} dark pixels");
        // the text is drawn: a long title darkens more pixels than a one-letter one
        let long = Plot {
            title: "A much longer title, drawn with the system's sans-serif font".into(),
            ..plot
        };
        let pix2 = Pixmap::decode_png(&svg_to_png(&long.to_svg()).unwrap()).unwrap();
        let dark2 = pix2
            .pixels()
            .iter()
            .filter(|p| p.red() < 128 && p.alpha() == 255)
            .count();
        assert!(
            dark2 > dark + 500,
            "title text: {dark2} vs {dark} dark pixels"
        );
    }
}
