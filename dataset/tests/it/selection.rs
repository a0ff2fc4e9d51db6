//! Near-duplicate removal and farthest-first selection.

use osmab_dataset::embedding::{Embedder, HashingEmbedder};
use osmab_dataset::prompts::grammar_pool;
use osmab_dataset::selection::{NEAR_DUPLICATE_COSINE, select};
use osmab_dataset::spec::Regime;

fn unit(v: &[f32]) -> Vec<f32> {
    let n = v.iter().map(|x| x * x).sum::<f32>().sqrt();
    v.iter().map(|x| x / n).collect()
}

fn ids(n: usize) -> Vec<String> {
    (0..n).map(|i| format!("p{i}")).collect()
}

#[test]
fn later_near_duplicates_are_removed_with_the_reason() {
    let e = vec![unit(&[1.0, 0.0, 0.0]), unit(&[1.0, 0.1, 0.0]), unit(&[0.0, 1.0, 0.0]), unit(&[0.0, 1.0, 0.6])];
    let report = select(&ids(4), &e, 10, NEAR_DUPLICATE_COSINE);
    assert_eq!(report.near_duplicates.len(), 1);
    assert_eq!((report.near_duplicates[0].id.as_str(), report.near_duplicates[0].duplicate_of.as_str()), ("p1", "p0"));
    assert!(report.near_duplicates[0].cosine > 0.99);
    assert_eq!(report.selected.len(), 3);
    assert_eq!(report.shortfall, 7);
}

#[test]
fn farthest_first_starts_at_the_first_prompt_and_takes_the_farthest_next() {
    let e = vec![unit(&[1.0, 0.0]), unit(&[0.9, 0.45]), unit(&[-1.0, 0.05]), unit(&[0.0, 1.0])];
    let report = select(&ids(4), &e, 3, 0.999);
    let order: Vec<&str> = report.selected.iter().map(|s| s.id.as_str()).collect();
    assert_eq!(order, ["p0", "p2", "p3"]);
    assert_eq!(report.selected[0].distance_to_earlier, None);
    assert!(report.selected[1].distance_to_earlier.unwrap() > 1.9);
    assert_eq!(report.not_selected, vec!["p1"]);
}

#[test]
fn the_builtin_embedding_sees_rephrasings_as_close_and_other_rooms_as_far() {
    let texts: Vec<String> = [
        "A bedroom with 1 bed against the wall and 2 nightstands next to the bed.",
        "A bedroom with 1 bed against the wall and 2 nightstands beside the bed.",
        "A workshop with 2 workbenches along the wall and 3 storage racks in the corner.",
    ]
    .map(String::from)
    .to_vec();
    let e = HashingEmbedder::default().embed(&texts).unwrap();
    let dot = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f32>();
    assert!(dot(&e[0], &e[1]) > 0.8, "one word changed");
    assert!(dot(&e[0], &e[2]) < 0.2, "another room, other furniture");
    assert!((dot(&e[0], &e[0]) - 1.0).abs() < 1e-6);
    assert_eq!(e, HashingEmbedder::default().embed(&texts).unwrap(), "deterministic");
}

#[test]
fn the_papers_pool_sizes_give_the_papers_selection() {
    // A pool of 350 (250 furniture + 100 manipuland) gives 24 + 16 distinct scenes.
    for (regime, pool_size, target) in [(Regime::Furniture, 250, 24), (Regime::Manipuland, 100, 16)] {
        let pool = grammar_pool(regime, pool_size, 42);
        let texts: Vec<String> = pool.accepted.iter().map(|p| p.text.clone()).collect();
        let ids: Vec<String> = pool.accepted.iter().map(|p| p.id.clone()).collect();
        let report = select(&ids, &HashingEmbedder::default().embed(&texts).unwrap(), target, NEAR_DUPLICATE_COSINE);
        assert_eq!(report.selected.len(), target, "{regime:?}");
        assert_eq!(report.candidates, report.near_duplicates.len() + report.selected.len() + report.not_selected.len());
    }
}
