//! The question odds as they bear out. The odds a layout tally gives ([`super::priors`])
//! drift from how often the answer turns out positive in scenes placed afresh: a form a
//! room's few layouts settle the same way gets near-certain odds, and near certainty is
//! where the draw is most sensitive (a "yes" at odds 0.995 is kept with chance 0.005; if
//! such forms turn out yes only 98.7 % of the time, their "no"s are asked 2.6 times as often
//! as their "yes"s, and the odds read backwards answer them). So every template's
//! candidates are noted on placements held out of the tally, and the odds are mapped to the
//! share of positive answers among held-out candidates of the same template and nearby
//! odds. The map follows from the published config like the odds themselves.

use std::collections::BTreeMap;

/// Bins of the odds' logit, `BIN_WIDTH` wide, from `−LOGIT_RANGE` to `LOGIT_RANGE`.
const LOGIT_RANGE: f64 = 8.0;
const BIN_WIDTH: f64 = 0.5;
const BINS: usize = (2.0 * LOGIT_RANGE / BIN_WIDTH) as usize;

/// Held-out candidates a bin needs before its own share outweighs the tally's odds.
const PRIOR_WEIGHT: f64 = 8.0;

/// One held-out candidate: its template (what asks it, and its form's kind: see
/// [`super::priors::template_key`]), the odds the tally gave it, and whether its answer was
/// positive (yes; a count above zero).
#[derive(Debug, Clone, PartialEq)]
pub struct Observed {
    pub template: String,
    pub odds: f64,
    pub positive: bool,
}

/// Positive answers and candidates per bin of odds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Bin {
    positive: f64,
    seen: f64,
}

/// The odds of each template mapped to how often they bear out.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Calibration {
    templates: BTreeMap<String, Vec<Bin>>,
}

fn bin_of(odds: f64) -> usize {
    let logit = (odds / (1.0 - odds)).ln();
    if logit.is_nan() {
        return BINS / 2;
    }
    (((logit + LOGIT_RANGE) / BIN_WIDTH).floor().max(0.0) as usize).min(BINS - 1)
}

impl Calibration {
    /// The calibration the held-out candidates `observed` give.
    pub fn fit(observed: &[Observed]) -> Self {
        let mut templates: BTreeMap<String, Vec<Bin>> = BTreeMap::new();
        for o in observed {
            let bins = templates.entry(o.template.clone()).or_insert_with(|| vec![Bin::default(); BINS]);
            let bin = &mut bins[bin_of(o.odds)];
            bin.seen += 1.0;
            bin.positive += f64::from(u8::from(o.positive));
        }
        Calibration { templates }
    }

    /// How often a candidate of `template` with tally odds `odds` turned out positive,
    /// drawn towards `odds` where its bin saw few.
    pub fn calibrated(&self, template: &str, odds: f64) -> f64 {
        match self.templates.get(template) {
            Some(bins) => {
                let bin = bins[bin_of(odds)];
                (bin.positive + PRIOR_WEIGHT * odds) / (bin.seen + PRIOR_WEIGHT)
            }
            None => odds,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn observed(odds: f64, positive: bool) -> Observed {
        Observed { template: "Standard rests_on".into(), odds, positive }
    }

    #[test]
    fn odds_that_overstate_certainty_are_brought_back_to_what_happened() {
        // Said 0.995, turned out positive 98.7 % of the time.
        let held_out: Vec<Observed> = (0..10_000).map(|k| observed(0.995, k % 1000 >= 13)).collect();
        let calibration = Calibration::fit(&held_out);
        let p = calibration.calibrated("Standard rests_on", 0.995);
        assert!((p - 0.987).abs() < 0.001, "{p}");
    }

    #[test]
    fn odds_with_few_or_no_held_out_candidates_stay_near_the_tally() {
        let calibration = Calibration::fit(&[observed(0.3, true)]);
        let p = calibration.calibrated("Standard rests_on", 0.3);
        assert!(p > 0.3 && p < 0.4, "one positive barely moves 0.3: {p}");
        assert_eq!(calibration.calibrated("Standard rests_on", 0.9), 0.9, "an empty bin keeps the odds");
        assert_eq!(calibration.calibrated("Standard count", 0.2), 0.2, "an unseen template keeps the odds");
    }

    #[test]
    fn every_odds_falls_in_a_bin() {
        for odds in [0.0, 1e-12, 0.5, 1.0 - 1e-12, 1.0, f64::NAN] {
            assert!(bin_of(odds) < BINS, "{odds}");
        }
    }
}
