//! No silent clipping: a line chart with a fixed y range that cuts data says so in its
//! title ("… (points: 3 above 200 cut)"), on the picture itself, where a reader looks.

use crate::line::LineChart;

impl LineChart {
    /// How many finite points of the lines fall below and above a fixed y range (0, 0
    /// without one). Bands are not counted: they are drawn clipped as shading.
    pub fn clipped_points(&self) -> (usize, usize) {
        let Some((lo, hi)) = self.y_range else { return (0, 0) };
        let ys = self.series.iter().flat_map(|s| s.y.iter().copied()).filter(|y| y.is_finite());
        ys.fold((0, 0), |(b, a), y| (b + usize::from(y < lo), a + usize::from(y > hi)))
    }

    /// The title with a note of the points a fixed y range cuts (the title as it is when
    /// nothing is cut).
    pub fn title_marking_clipping(&self) -> String {
        let (below, above) = self.clipped_points();
        let Some((lo, hi)) = self.y_range else { return self.title.clone() };
        let mut parts = Vec::new();
        if below > 0 {
            parts.push(format!("{below} below {} cut", num(lo)));
        }
        if above > 0 {
            parts.push(format!("{above} above {} cut", num(hi)));
        }
        if parts.is_empty() {
            self.title.clone()
        } else {
            format!("{} (points: {})", self.title, parts.join(", "))
        }
    }
}

fn num(x: f64) -> String {
    let s = format!("{x}");
    s.replacen('-', "−", 1)
}

#[cfg(test)]
mod tests {
    use crate::{LineChart, Series};

    #[test]
    fn clipping_is_counted_and_named() {
        let mut c = LineChart::new("t", "x", "y");
        c.series.push(Series::new("a", vec![0.0, 1.0, 2.0, 3.0], vec![-100.0, 50.0, 300.0, f64::NAN]));
        assert_eq!(c.title_marking_clipping(), "t");
        c.y_range = Some((-60.0, 200.0));
        assert_eq!(c.clipped_points(), (1, 1));
        assert_eq!(c.title_marking_clipping(), "t (points: 1 below −60 cut, 1 above 200 cut)");
        c.y_range = Some((-200.0, 400.0));
        assert_eq!(c.title_marking_clipping(), "t");
    }
}
