//! Tick labels of a categorical x axis: each name is wrapped to the width of its slot at
//! its ` · ` separators first, then at spaces, shrunk if a word is still too wide, and
//! cut with an ellipsis beyond three lines.

use crate::render::text_size;

/// Most lines of one label.
const MAX_LINES: usize = 3;
/// Smallest font a label is shrunk to.
const MIN_FONT: f64 = 11.0;

/// The lines of every category label and their common font size.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct CategoryLabels {
    pub lines: Vec<Vec<String>>,
    pub font: f64,
}

impl CategoryLabels {
    /// Lays out `names` for slots `slot_w` wide at `font` or smaller.
    pub fn fit(names: &[String], slot_w: f64, font: f64) -> CategoryLabels {
        let mut lines: Vec<Vec<String>> = names.iter().map(|n| wrap(n, slot_w, font)).collect();
        let widest = lines.iter().flatten().map(|l| text_size(l, font).0).fold(0.0, f64::max);
        let font = if widest > slot_w { (font * slot_w / widest).max(MIN_FONT) } else { font };
        for label in &mut lines {
            if label.len() > MAX_LINES {
                label.truncate(MAX_LINES);
                label[MAX_LINES - 1].push('…');
            }
        }
        CategoryLabels { lines, font }
    }

    /// Distance between the tops of two lines.
    pub fn pitch(&self) -> f64 {
        text_size("0", self.font).1 + 0.3 * self.font
    }

    /// Height of the tallest label.
    pub fn height(&self) -> f64 {
        let n = self.lines.iter().map(Vec::len).max().unwrap_or(1).max(1);
        self.pitch() * (n - 1) as f64 + text_size("0", self.font).1
    }
}

/// `name` in lines no wider than `max_w` where it can be: parts separated by ` · ` are
/// joined while they fit; a part too wide alone is split at its spaces.
fn wrap(name: &str, max_w: f64, font: f64) -> Vec<String> {
    let fits = |s: &str| text_size(s, font).0 <= max_w;
    let mut pieces: Vec<(String, &str)> = Vec::new();
    for part in name.split(" · ") {
        if fits(part) {
            pieces.push((part.to_string(), " · "));
        } else {
            pieces.extend(part.split(' ').map(|w| (w.to_string(), " ")));
        }
    }
    let mut lines: Vec<String> = Vec::new();
    let mut cur = String::new();
    let mut sep = "";
    for (piece, next_sep) in pieces {
        let joined = format!("{cur}{sep}{piece}");
        if cur.is_empty() || fits(&joined) {
            cur = joined;
        } else {
            lines.push(std::mem::take(&mut cur));
            cur = piece;
        }
        sep = next_sep;
    }
    if !cur.is_empty() || lines.is_empty() {
        lines.push(cur);
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_wrap_at_separators_to_their_slot() {
        let names: Vec<String> =
            ["grid · poisson:13", "robot · exponential:48s · profile=realistic"].map(String::from).to_vec();
        let l = CategoryLabels::fit(&names, 1000.0, 17.0);
        assert_eq!(l.lines[1], vec![names[1].clone()]);
        let l = CategoryLabels::fit(&names, 160.0, 17.0);
        assert_eq!(l.lines[1], vec!["robot", "exponential:48s", "profile=realistic"]);
        assert!(l.lines.iter().flatten().all(|s| text_size(s, l.font).0 <= 160.0));
        assert!(l.height() > 2.0 * text_size("0", l.font).1);
        let l = CategoryLabels::fit(&["a b c d e f".to_string()], 1.0, 17.0);
        assert_eq!(l.lines[0].len(), MAX_LINES);
        assert_eq!(l.lines[0][2], "c…");
        assert_eq!(l.font, MIN_FONT);
    }
}
