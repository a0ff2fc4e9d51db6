//! The one SVG chart of the pages: grouped bars (one group per lighting, one bar per
//! method, the first eight), a horizontal grid, group labels and a legend. Values are
//! fractions; the axis is either 0–100 % or fitted to the data around zero (relative
//! changes). A method keeps its colour on every chart (its name picks it), and a zero
//! value still draws a mark on the axis.

use super::format::escape_xml;

/// Bar colours; a method's name picks one ([`colours`]).
const PALETTE: [&str; 8] = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"];

/// At most this many methods are drawn.
const SHOWN: usize = 8;

/// The value axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Axis {
    /// 0 to 100 %.
    Fraction,
    /// From the lowest to the highest value, zero included, each end rounded out to 5 %
    /// (at most ±100 %).
    Change,
}

/// The size of a chart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Size {
    /// The page-wide robustness figure.
    Wide,
    /// One of a row of small charts.
    Small,
    /// The robustness figure on a phone: the same content in a 360-unit-wide box, so its
    /// text stays legible when the page is 390 px wide.
    Narrow,
}

/// The colour of each of `names`: the palette entry its name hashes to, or the next one
/// not taken by an earlier name of the same chart. The same method gets the same colour
/// on every board and chart unless it collides there.
fn colours(names: &[&str]) -> Vec<&'static str> {
    let mut taken = [false; PALETTE.len()];
    names
        .iter()
        .map(|name| {
            // FNV-1a: stable across builds and platforms.
            let hash = name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3));
            let start = (hash % PALETTE.len() as u64) as usize;
            let slot = (0..PALETTE.len()).map(|k| (start + k) % PALETTE.len()).find(|&k| !taken[k]).unwrap_or(start);
            taken[slot] = true;
            PALETTE[slot]
        })
        .collect()
}

/// One method's bars: its name and a value per group (`None`: no bar).
pub struct Series {
    pub name: String,
    pub values: Vec<Option<f64>>,
}

/// A grouped bar chart.
pub struct BarChart {
    /// Read by screen readers; Small charts also print it above the plot.
    pub title: String,
    /// Group labels under the axis.
    pub groups: Vec<String>,
    /// Group names in the bars' tooltips (the full names where `groups` are short).
    pub group_titles: Vec<String>,
    pub series: Vec<Series>,
    pub axis: Axis,
    pub size: Size,
}

struct Layout {
    width: f64,
    height: f64,
    top: f64,
    bottom: f64,
    left: f64,
    max_bar: f64,
    legend_columns: usize,
    legend_step: f64,
    swatch: f64,
    /// How far a swatch's top sits above its legend text's baseline.
    swatch_lift: f64,
    /// Gap between the axis and its tick labels.
    tick_gap: f64,
    /// Group labels' baseline below the plot.
    label_drop: f64,
}

/// One of a row of small charts.
const SMALL: Layout = Layout {
    width: 360.0,
    height: 250.0,
    top: 24.0,
    bottom: 84.0,
    left: 40.0,
    max_bar: 18.0,
    legend_columns: 2,
    legend_step: 160.0,
    swatch: 8.0,
    swatch_lift: 8.0,
    tick_gap: 4.0,
    label_drop: 16.0,
};

impl BarChart {
    fn layout(&self) -> Layout {
        match self.size {
            Size::Wide => Layout {
                width: 720.0,
                height: 260.0,
                top: 20.0,
                bottom: 60.0,
                left: 50.0,
                max_bar: 28.0,
                legend_columns: 4,
                legend_step: 165.0,
                swatch: 10.0,
                swatch_lift: 9.0,
                tick_gap: 6.0,
                label_drop: 18.0,
            },
            // The small layout with room for the wide chart's longer tick labels.
            Size::Narrow => Layout { top: 16.0, left: 46.0, max_bar: 16.0, ..SMALL },
            Size::Small => SMALL,
        }
    }

    /// The chart as inline SVG; empty without groups or series.
    pub fn to_svg(&self) -> String {
        let shown = &self.series[..self.series.len().min(SHOWN)];
        if shown.is_empty() || self.groups.is_empty() {
            return String::new();
        }
        let l = self.layout();
        let plot = self.plot(&l, shown);
        let palette = colours(&shown.iter().map(|s| s.name.as_str()).collect::<Vec<_>>());
        let mut svg = self.opening(&l);
        svg.push_str(&self.grid(&l, &plot));
        svg.push_str(&self.bars(&l, &plot, shown, &palette));
        svg.push_str(&self.legend(&l, shown, &palette));
        svg.push_str("</svg>");
        svg
    }

    /// The value range of the axis and where values land.
    fn plot(&self, l: &Layout, shown: &[Series]) -> Plot {
        let (lo, hi) = match self.axis {
            Axis::Fraction => (0.0, 1.0),
            Axis::Change => {
                let values = || shown.iter().flat_map(|s| s.values.iter().flatten().copied()).filter(|v| v.is_finite());
                let round_out = |v: f64| (v.abs().min(1.0) * 20.0).ceil() / 20.0;
                let (lo, hi) = (-round_out(values().fold(0.0f64, f64::min)), round_out(values().fold(0.0f64, f64::max)));
                if lo == 0.0 && hi == 0.0 { (-0.05, 0.05) } else { (lo, hi) }
            }
        };
        let scale = (l.height - l.top - l.bottom) / (hi - lo);
        Plot { lo, hi, scale, zero: l.top + hi * scale }
    }

    /// The `<svg>` tag with its title (and, small, its heading).
    fn opening(&self, l: &Layout) -> String {
        let (class, title) = match self.size {
            Size::Wide => ("chart wide", format!("<title id=\"chart-title\">{}</title>", escape_xml(&self.title))),
            Size::Narrow => ("chart narrow", format!("<title id=\"chart-title-narrow\">{}</title>", escape_xml(&self.title))),
            Size::Small => (
                "chart small",
                format!("<title>{0} accuracy per lighting</title><text x=\"{1}\" y=\"14\" class=\"legend\">{0} (%)</text>", escape_xml(&self.title), l.left),
            ),
        };
        let labelled = match self.size {
            Size::Wide => " aria-labelledby=\"chart-title\"",
            Size::Narrow => " aria-labelledby=\"chart-title-narrow\"",
            Size::Small => "",
        };
        format!("<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {} {}\" role=\"img\"{labelled} class=\"{class}\">{title}", l.width, l.height)
    }

    /// A value as the axis and the bars' titles write it.
    fn label(&self, value: f64, decimals: usize) -> String {
        match self.axis {
            Axis::Fraction => format!("{:.*}", decimals, value * 100.0),
            Axis::Change => format!("{:+.1}%", value * 100.0),
        }
    }

    /// The grid lines with their tick labels.
    fn grid(&self, l: &Layout, plot: &Plot) -> String {
        let mut ticks = vec![plot.lo, plot.lo / 2.0, 0.0, plot.hi / 2.0, plot.hi];
        ticks.dedup_by(|a, b| a == b);
        ticks
            .into_iter()
            .map(|tick| {
                let y = plot.zero - tick * plot.scale;
                format!(
                    "<line x1=\"{}\" x2=\"{}\" y1=\"{y:.1}\" y2=\"{y:.1}\" class=\"grid\"/><text x=\"{}\" y=\"{:.1}\" class=\"axis\" text-anchor=\"end\">{}</text>",
                    l.left,
                    l.width - 10.0,
                    l.left - l.tick_gap,
                    y + 4.0,
                    self.label(tick, 0)
                )
            })
            .collect()
    }

    /// Every group's bars, one per series, and the group's label.
    fn bars(&self, l: &Layout, plot: &Plot, shown: &[Series], palette: &[&str]) -> String {
        let mut svg = String::new();
        let group_w = (l.width - l.left - 10.0) / self.groups.len() as f64;
        let bar_w = (group_w * 0.8 / shown.len() as f64).min(l.max_bar);
        for (g, group) in self.groups.iter().enumerate() {
            let x0 = l.left + g as f64 * group_w + group_w * 0.1;
            for (i, series) in shown.iter().enumerate() {
                let Some(v) = series.values.get(g).copied().flatten() else { continue };
                let (y, bar_h) = plot.bar(v);
                let shown_value = match self.axis {
                    Axis::Fraction => format!("{}%", self.label(v, 1)),
                    Axis::Change => self.label(v, 1),
                };
                svg.push_str(&format!(
                    "<rect x=\"{:.1}\" y=\"{y:.1}\" width=\"{bar_w:.1}\" height=\"{:.1}\" fill=\"{}\"><title>{} — {}: {shown_value}</title></rect>",
                    x0 + i as f64 * bar_w,
                    bar_h,
                    palette[i],
                    escape_xml(&series.name),
                    escape_xml(self.group_titles.get(g).unwrap_or(group)),
                ));
            }
            svg.push_str(&format!(
                "<text x=\"{:.1}\" y=\"{:.1}\" class=\"axis\" text-anchor=\"middle\">{}</text>",
                l.left + g as f64 * group_w + group_w / 2.0,
                l.height - l.bottom + l.label_drop,
                escape_xml(group)
            ));
        }
        svg
    }

    /// A swatch and the (shortened) name of every series.
    fn legend(&self, l: &Layout, shown: &[Series], palette: &[&str]) -> String {
        let legend_top = match self.size {
            Size::Wide => l.height - 22.0,
            Size::Small | Size::Narrow => l.height - l.bottom + 34.0,
        };
        let row_h = l.swatch + 4.0;
        shown
            .iter()
            .enumerate()
            .map(|(i, series)| {
                let x = l.left + (i % l.legend_columns) as f64 * l.legend_step;
                let y = legend_top + (i / l.legend_columns) as f64 * row_h;
                format!(
                    "<rect x=\"{x:.1}\" y=\"{:.1}\" width=\"{s}\" height=\"{s}\" fill=\"{}\"/><text x=\"{:.1}\" y=\"{y:.1}\" class=\"legend\">{}</text>",
                    y - l.swatch_lift,
                    palette[i],
                    x + l.swatch + 4.0,
                    escape_xml(&series.name.chars().take(22).collect::<String>()),
                    s = l.swatch,
                )
            })
            .collect()
    }
}

/// The axis's range and where a value lands: the zero line and the height of one unit.
struct Plot {
    lo: f64,
    hi: f64,
    scale: f64,
    zero: f64,
}

impl Plot {
    /// The top and height of the bar of `value` (clamped to the range). A zero (or nearly
    /// zero) value is a 2-unit mark across the axis, not nothing.
    fn bar(&self, value: f64) -> (f64, f64) {
        let h = value.clamp(self.lo, self.hi) * self.scale;
        if h.abs() < 2.0 {
            (self.zero - 1.0, 2.0)
        } else if h >= 0.0 {
            (self.zero - h, h)
        } else {
            (self.zero, -h)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart(axis: Axis, values: Vec<Option<f64>>) -> String {
        BarChart {
            title: "T <1>".into(),
            groups: vec!["Camera".into(), "Dynamic".into()],
            group_titles: vec!["Camera Light".into(), "Dynamic Lights".into()],
            series: vec![Series { name: "m&m".into(), values }],
            axis,
            size: Size::Wide,
        }
        .to_svg()
    }

    #[test]
    fn a_bar_per_defined_value_with_escaped_names() {
        let svg = chart(Axis::Change, vec![Some(-0.2), None]);
        assert_eq!(svg.matches("<rect").count(), 2, "one bar and one legend swatch");
        assert!(svg.contains("m&amp;m — Camera Light: -20.0%") && svg.contains("T &lt;1&gt;"), "tooltips name the group in full: {svg}");
        assert!(svg.contains(">-20.0%</text>"), "the axis reaches the largest drop: {svg}");
        assert!(!svg.contains(">+20.0%</text>") && svg.contains(">+0.0%</text>"), "and stops at zero when nothing rose: {svg}");
    }

    #[test]
    fn a_zero_change_still_draws_a_mark_on_the_axis() {
        let svg = chart(Axis::Change, vec![Some(0.0), Some(-0.4)]);
        let zero_bar = svg.split("<rect").nth(1).unwrap();
        assert!(zero_bar.contains("height=\"2.0\""), "a 2-unit mark: {zero_bar}");
    }

    #[test]
    fn a_method_keeps_its_colour_whatever_the_order_and_two_methods_never_share_one() {
        let one = colours(&["alpha", "beta", "gamma"]);
        let other = colours(&["gamma", "alpha", "beta"]);
        assert_eq!((one[0], one[1], one[2]), (other[1], other[2], other[0]));
        let many: Vec<String> = (0..8).map(|i| format!("method-{i}")).collect();
        let picked = colours(&many.iter().map(String::as_str).collect::<Vec<_>>());
        let distinct: std::collections::BTreeSet<_> = picked.iter().collect();
        assert_eq!(distinct.len(), 8, "eight methods, eight colours: {picked:?}");
    }

    #[test]
    fn no_groups_or_series_draw_nothing() {
        let empty = BarChart { title: String::new(), groups: vec![], group_titles: vec![], series: vec![], axis: Axis::Fraction, size: Size::Small };
        assert_eq!(empty.to_svg(), "");
        assert!(chart(Axis::Fraction, vec![Some(0.5), Some(1.5)]).contains("height=\"180.0\""), "values above 100 % stop at the top");
    }
}
