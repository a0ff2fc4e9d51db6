//! A release's own front matter: `README.md` (what is in it and how to use it),
//! `LICENSE` (the terms of its parts) and `CITATION.cff` (how to cite it), written from its
//! config and scenes like every other file (listed in the manifest, covered by the digest,
//! the same bytes for the same config and secret).

use std::path::Path;

use osmab_evaluator::Result;
use osmab_evaluator::scores::{ReleaseLighting, Split};

use super::config::ReleaseConfig;

/// The files, relative to the release root.
pub const FILES: [&str; 3] = ["README.md", "LICENSE", "CITATION.cff"];

/// What the front matter says of the release's scenes.
pub struct Contents<'a> {
    pub config: &'a ReleaseConfig,
    /// Each scene's split, in order.
    pub splits: &'a [Split],
    pub lightings: &'a [ReleaseLighting],
}

/// Write the three files into `out`.
pub fn write(out: &Path, contents: &Contents<'_>) -> Result<()> {
    for (name, text) in FILES.iter().zip([readme(contents), licence(contents.config), citation(contents.config)]) {
        let path = out.join(name);
        std::fs::write(&path, text).map_err(|e| osmab_evaluator::InputError::io(&path, &e))?;
    }
    Ok(())
}

fn readme(c: &Contents<'_>) -> String {
    let test = c.splits.iter().filter(|s| **s == Split::Test).count();
    let val = c.splits.len() - test;
    let version = &c.config.version;
    format!(
        "# OSMa-Bench++ release {version}\n\n\
Synthetic indoor scenes rendered as RGB-D + semantic sequences for evaluating open semantic mapping (release dated {created}, built by osmab).\n\n\
- {scenes} scenes: {test} in the hidden **test** split (colour, depth and camera paths only: their semantics, prompts and \
questions stay with the server, which scores submissions on them) and {val} in the open **val** split (everything, \
ground truth included, so methods can be scored offline with `osmab client validate`).\n\
- Lightings: {lightings}.\n\
- Resolution {w}×{h}, horizontal field of view {hfov}°.\n\n\
## Layout\n\n\
- `sequences/<lighting>/<scene>/`: `results/frameNNNNNN.jpg` (colour), `results/depthNNNNNN.png` (16-bit, metres × 6553.5), \
`traj.txt` (camera-to-world poses), `camera_params.*`, and ConceptGraphs' and BBQ's dataset configs; a val scene also \
has its semantic frames.\n\
- `scenes/<scene>/prompt.json`, `questions/<scene>.json`: a val scene's generating prompt and its questions (without answers).\n\
- `classes.json`: the class list; `quality/`: the quality report and contact sheets of every sequence.\n\
- `manifest.json`: every file with its size and SHA-256, and the release digest over them.\n\n\
## Check, use, submit\n\n\
- `osmab release verify <this folder>` checks every file against the manifest.\n\
- Run your mapping method on each sequence, then `osmab client submit <folder>` (see the service's About page and \
`docs/participants.md` in the osmab repository for the submission layout).\n\
- Cite the release by its version and digest (`CITATION.cff`); the terms are in `LICENSE`.\n",
        created = c.config.created,
        scenes = c.splits.len(),
        lightings = c.lightings.iter().map(|l| l.name()).collect::<Vec<_>>().join(", "),
        w = c.config.render.width,
        h = c.config.render.height,
        hfov = c.config.render.hfov,
    )
}

fn licence(config: &ReleaseConfig) -> String {
    let data = match &config.licence {
        Some(spdx) => format!("The renders, annotations, prompts and questions of this release are licensed under {spdx}."),
        None => "The operator who built this release named no licence for its renders, annotations, prompts and questions \
(the release config's `licence`); ask them before redistributing."
            .to_string(),
    };
    format!(
        "OSMa-Bench++ release {version}\n\n\
{data}\n\n\
Parts with their own terms:\n\
- Object and room-shell assets from the asset pack named in the manifest's `generator` (the bundled pack: Infinigen, \
BSD-3-Clause, Princeton University; each asset's licence is in the pack's catalogue.json).\n\
- osmab, the software that built and scores the release: MIT licence.\n",
        version = config.version
    )
}

fn citation(config: &ReleaseConfig) -> String {
    let licence = config.licence.as_deref().map(|l| format!("license: \"{l}\"\n")).unwrap_or_default();
    format!(
        "cff-version: 1.2.0\n\
message: \"If you use this release, cite it by its version and digest (manifest.json) as below.\"\n\
type: dataset\n\
title: \"OSMa-Bench++ release {version}\"\n\
version: \"{version}\"\n\
date-released: \"{created}\"\n\
{licence}\
authors:\n  - name: \"OSMa-Bench++ organisers\"\n\
keywords:\n  - open semantic mapping\n  - benchmark\n  - RGB-D\n  - robot manipulation\n",
        version = config.version,
        created = config.created,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The repository's demo config with `licence` set to `value` (a TOML literal).
    fn config_with_licence(value: &str) -> Result<ReleaseConfig> {
        let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../configs/release-demo.toml")).unwrap();
        ReleaseConfig::parse(&format!("licence = {value}\n{text}"), Path::new("release.toml")).map(|(c, _)| c)
    }

    #[test]
    fn a_named_licence_is_the_data_licence_in_license_and_citation() {
        let config = config_with_licence("\"CC-BY-4.0\"").unwrap();
        assert!(licence(&config).contains("are licensed under CC-BY-4.0."));
        assert!(citation(&config).contains("license: \"CC-BY-4.0\"\n"));
        let readme = readme(&Contents {
            config: &config,
            splits: &[Split::Test, Split::Val, Split::Test],
            lightings: &[ReleaseLighting::Baseline, ReleaseLighting::Camera],
        });
        assert!(readme.contains("3 scenes: 2 in the hidden **test** split") && readme.contains("1 in the open **val** split"), "{readme}");
    }

    #[test]
    fn a_licence_that_could_break_the_citation_file_is_refused_naming_the_field() {
        let refused = config_with_licence("\"MIT\\\"\\nauthors: []\"").unwrap_err().to_string();
        assert!(refused.contains("licence") && refused.contains("SPDX"), "{refused}");
    }
}
