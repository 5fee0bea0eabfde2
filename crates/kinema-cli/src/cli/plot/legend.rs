//! Legends, drawn in strips of their own so that they never hide a curve.

use plotters::prelude::*;

use super::{Area, Drawn, text};

/// What a legend entry shows.
#[derive(Debug, Clone, Copy)]
pub(super) enum Swatch {
    /// A line of this colour and width.
    Line(RGBColor, u32),
    /// A ground triangle.
    Pivot,
    /// A joint circle.
    Joint,
    /// No swatch: the label is a heading.
    Heading,
}

pub(super) fn draw_swatch(area: &Area<'_>, swatch: Swatch, x: i32, y: i32) -> Drawn {
    match swatch {
        Swatch::Line(color, width) => {
            area.draw(&PathElement::new(
                vec![(x, y), (x + 26, y)],
                color.stroke_width(width),
            ))?;
        }
        Swatch::Pivot => {
            let c = x + 13;
            area.draw(&Polygon::new(
                vec![(c, y - 6), (c - 7, y + 5), (c + 7, y + 5)],
                RGBColor(120, 120, 120).mix(0.35).filled(),
            ))?;
            area.draw(&PathElement::new(
                vec![(c - 10, y + 5), (c + 10, y + 5)],
                BLACK.stroke_width(2),
            ))?;
        }
        Swatch::Joint => {
            area.draw(&Circle::new((x + 13, y), 4, BLACK.stroke_width(1)))?;
        }
        Swatch::Heading => {}
    }
    Ok(())
}

/// A legend as a column of entries, top left of `area`; headings
/// ([`Swatch::Heading`]) start groups.
pub(super) fn draw_legend_column(area: &Area<'_>, entries: &[(String, Swatch)]) -> Drawn {
    let (w, h) = area.dim_in_pixel();
    let max_chars = (w.saturating_sub(50) / 7).max(8) as usize;
    let mut y = 50;
    for (label, swatch) in entries {
        if y + 20 > h as i32 {
            area.draw_text("…", &text(13), (40, y - 7))?;
            break;
        }
        if let Swatch::Heading = swatch {
            y += 6;
            area.draw_text(&shorten(label, max_chars + 4), &text(14), (6, y - 7))?;
        } else {
            draw_swatch(area, *swatch, 6, y)?;
            area.draw_text(&shorten(label, max_chars), &text(13), (40, y - 7))?;
        }
        y += 21;
    }
    Ok(())
}

/// A legend as a row of entries.
pub(super) fn draw_legend_row(area: &Area<'_>, entries: &[(String, Swatch)]) -> Drawn {
    let (w, _) = area.dim_in_pixel();
    let (mut x, mut y) = (70, 12);
    for (label, swatch) in entries {
        let label = shorten(label, 40);
        let width = 40 + 8 * label.chars().count() as i32;
        if x + width > w as i32 && x > 70 {
            x = 70;
            y += 20;
        }
        draw_swatch(area, *swatch, x, y)?;
        area.draw_text(&label, &text(13), (x + 32, y - 7))?;
        x += width + 16;
    }
    Ok(())
}

pub(super) fn shorten(s: &str, max: usize) -> String {
    if s.chars().count() <= max {
        s.to_string()
    } else {
        let mut out: String = s.chars().take(max.saturating_sub(1)).collect();
        out.push('…');
        out
    }
}
