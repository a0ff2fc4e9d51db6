//! The leaderboard of a release's split (the hidden test split is the main board, the
//! open val split has its own): every scored public submission to it (and the baselines) with
//! the summary of its latest score, ranked by pooled mIoU under the release's first
//! lighting, with rank groups and robustness columns ([`ranking`]). [`cache`] builds it
//! at most once per second per release and serves it from memory as ready JSON and CSV
//! ([`csv`]); [`vqa`] derives the paper's VQA tables.
//!
//! The board's wire types are [`osmab_api::leaderboard`]'s.

pub mod cache;
pub mod csv;
pub mod ranking;
pub mod vqa;

use osmab_evaluator::scores::{Aggregate, Lighting, Metric, Split};

pub use cache::{LeaderboardCache, Rendered};
pub use osmab_api::leaderboard::{Entry, Leaderboard, Robustness};
use ranking::{MIN_SCENES_FOR_GROUPS, Standing, rank_groups};

use crate::store::LeaderboardRow;

pub use crate::reserved_names::ANONYMOUS;

/// The board of `rows` of `release` made to `split` (of the release's `splits`), ranked:
/// pooled mIoU under the first lighting, best first, then the earlier submission; an
/// entry without that metric last.
pub fn rank(release: &str, lightings: Vec<Lighting>, split: Split, splits: Vec<Split>, rows: Vec<LeaderboardRow>) -> Leaderboard {
    let key = lightings.first().copied().unwrap_or(Lighting::BASELINE);
    let scenes = rows
        .iter()
        .filter(|row| row.split == split)
        .filter_map(|row| row.scores.semseg.get(&key).map(|l| l.pooled.unwrap_or(l.scenes.len())))
        .max()
        .unwrap_or(0);
    let significance = scenes >= MIN_SCENES_FOR_GROUPS;
    let mut ranked: Vec<(Entry, Standing)> = rows
        .into_iter()
        .filter(|row| row.split == split)
        .map(|row| {
            // Shown and ranked by what may be shown (Scores::disclosed); the replicates,
            // never shown, still tell which entries are within noise of each other.
            let shown = row.scores.disclosed();
            let standing = Standing {
                value: shown.semseg(key, None, Aggregate::Overall, Metric::Miou),
                replicates: row
                    .scores
                    .semseg
                    .get(&key)
                    .filter(|_| significance && shown.semseg.contains_key(&key))
                    .map(|l| l.bootstrap_miou.clone())
                    .unwrap_or_default(),
            };
            let reference = row.baseline && crate::reserved_names::is_reference_mapper(&row.card.name);
            let card = row.card;
            let entry = Entry {
                anonymous: card.anonymous,
                baseline: row.baseline,
                code_url: card.code_url.filter(|_| !card.anonymous),
                complete: row.complete,
                flagged: row.flag,
                method: card.name,
                paper_url: card.paper_url.filter(|_| !card.anonymous),
                rank: 0,
                rank_group: 0,
                reference,
                robustness: Robustness::of(&shown, &lightings),
                scores: if significance { shown.summary() } else { shown.summary().without_intervals() },
                submission_id: row.submission_id,
                submitted_at: crate::clock::rfc3339(row.created_at),
                team: if card.anonymous { ANONYMOUS.to_string() } else { row.team },
            };
            (entry, standing)
        })
        .collect();
    let rank_metric = |s: &Standing| s.value.unwrap_or(f64::NEG_INFINITY);
    ranked.sort_by(|(a, sa), (b, sb)| rank_metric(sb).total_cmp(&rank_metric(sa)).then_with(|| a.submitted_at.cmp(&b.submitted_at)));
    let (mut entries, standings): (Vec<Entry>, Vec<Standing>) = ranked.into_iter().unzip();
    for ((rank, entry), group) in entries.iter_mut().enumerate().zip(rank_groups(&standings)) {
        entry.rank = rank + 1;
        entry.rank_group = group;
    }
    Leaderboard { entries, lightings, release: release.to_string(), split, splits, scenes, significance }
}
