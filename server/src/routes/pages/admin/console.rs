//! `GET /admin`: releases (publish a draft, compare its quality), the regeneration form,
//! recent builds with their render jobs, recent submissions (flag, refund); and
//! `GET /admin/jobs/{id}`: one build's stages and render jobs, refreshing while it runs.

use askama::Template;
use askama_web::WebTemplate;
use axum::extract::State;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use serde::Deserialize;

use super::{AdminMessage, AdminSession};
use crate::clock::rfc3339;
use crate::jobs::Job;
use crate::jobs::progress::{Progress, Stage};
use crate::jobs::release_build::{BuildRelease, RenderSequence};
use crate::routes::extract::{ApiPath, ApiQuery};
use crate::state::AppState;
use crate::store::{JobRecord, JobState, ReleaseState, StoreError};

pub struct ReleaseRow {
    pub version: String,
    pub state: String,
    pub current: bool,
    pub draft: bool,
    pub created_at: String,
    pub published_at: String,
}

/// A build and how far its render jobs are.
pub struct BuildRow {
    pub job: String,
    pub version: String,
    pub state: JobState,
    pub stage: String,
    pub message: String,
    pub renders: RenderCounts,
    pub created_at: String,
}

#[derive(Default)]
pub struct RenderCounts {
    pub total: usize,
    pub succeeded: usize,
    pub running: usize,
    pub failed: usize,
}

pub struct SubmissionRow {
    pub id: String,
    pub method: String,
    pub team: String,
    pub state: String,
    pub created_at: String,
    pub baseline: bool,
    pub flag: Option<String>,
    pub quota_refunded: bool,
}

#[derive(Template, WebTemplate)]
#[template(path = "admin.html")]
pub struct ConsolePage {
    pub notice: Option<String>,
    pub form_token: String,
    pub releases: Vec<ReleaseRow>,
    pub builds: Vec<BuildRow>,
    pub submissions: Vec<SubmissionRow>,
    /// The regeneration form's starting point: the demo config under a version no release
    /// or build uses yet.
    pub demo_config: String,
    pub refresh: bool,
    /// Every split's submission limit.
    pub quotas: Vec<crate::routes::quota_policies::PolicyView>,
    pub teams: Vec<TeamRow>,
    /// Requests for access waiting for a decision, oldest first.
    pub access_requests: Vec<crate::access_requests::AccessRequestView>,
}

#[derive(Debug, Deserialize, Default)]
pub struct ConsoleQuery {
    notice: Option<String>,
    seal: Option<String>,
}

fn progress_of(job: &JobRecord) -> Progress {
    Progress::read(&job.progress)
}

/// How far the render jobs of `version` among `jobs` are.
fn renders_of(jobs: &[JobRecord], version: &str) -> RenderCounts {
    let mut counts = RenderCounts::default();
    for j in jobs.iter().filter(|j| j.kind == RenderSequence::KIND && RenderSequence::version_of_subject(&j.subject) == version) {
        counts.total += 1;
        match j.state {
            JobState::Succeeded => counts.succeeded += 1,
            JobState::Running => counts.running += 1,
            JobState::Failed => counts.failed += 1,
            _ => {}
        }
    }
    counts
}

fn build_row(job: &JobRecord, jobs: &[JobRecord]) -> BuildRow {
    let progress = progress_of(job);
    BuildRow {
        job: job.id.clone(),
        version: job.subject.clone(),
        state: job.state,
        stage: progress.stage.map_or("", Stage::name).to_string(),
        message: progress.message,
        renders: renders_of(jobs, &job.subject),
        created_at: rfc3339(job.created_at),
    }
}

/// `GET /admin`.
pub async fn console(State(state): State<AppState>, session: AdminSession, ApiQuery(query): ApiQuery<ConsoleQuery>) -> Response {
    let loaded = async {
        let releases = state.store.releases().await?;
        let jobs = state.store.jobs(2000).await?;
        let submissions = state.store.submissions(None, 200).await?;
        let teams = state.store.teams().await?;
        let pending = state.store.access_requests(Some(crate::store::AccessRequestState::Pending)).await?;
        Ok::<_, StoreError>((releases, jobs, submissions, teams, pending))
    };
    let (releases, jobs, submissions, teams, pending) = match loaded.await {
        Ok(loaded) => loaded,
        Err(e) => return AdminMessage::problem(e.into()),
    };
    let quotas = match crate::routes::quota_policies::views(&state).await {
        Ok(quotas) => quotas,
        Err(problem) => return AdminMessage::problem(problem),
    };
    let team_name = |id: &str| teams.iter().find(|t| t.id == id).map_or_else(|| id.to_string(), |t| t.name.clone());
    let builds: Vec<BuildRow> = jobs.iter().filter(|j| j.kind == BuildRelease::KIND).take(10).map(|j| build_row(j, &jobs)).collect();
    ConsolePage {
        // Only notices this server wrote for this session (see `AdminSession::seal`).
        notice: query.notice.filter(|n| query.seal.as_deref() == Some(session.seal(n).as_str())),
        form_token: session.form_token(),
        refresh: builds.iter().any(|b| matches!(b.state, JobState::Queued | JobState::Running)),
        releases: releases
            .iter()
            .map(|r| ReleaseRow {
                version: r.version.clone(),
                state: r.state.to_string(),
                current: r.is_current,
                draft: r.state == ReleaseState::Draft,
                created_at: rfc3339(r.created_at),
                published_at: r.published_at.map(rfc3339).unwrap_or_default(),
            })
            .collect(),
        builds,
        submissions: submissions
            .iter()
            .map(|s| SubmissionRow {
                id: s.id.clone(),
                method: s.card.name.clone(),
                team: team_name(&s.team_id),
                state: s.state.to_string(),
                created_at: rfc3339(s.created_at),
                baseline: s.baseline,
                flag: s.flag.clone(),
                quota_refunded: s.quota_refunded,
            })
            .collect(),
        demo_config: with_free_version(
            crate::jobs::release_build::DEMO_CONFIG,
            &releases
                .iter()
                .map(|r| r.version.clone())
                // A build's subject is the version it builds.
                .chain(jobs.iter().filter(|j| j.kind == BuildRelease::KIND).map(|j| j.subject.clone()))
                .collect(),
        ),
        quotas,
        access_requests: pending.iter().map(crate::access_requests::AccessRequestView::from).collect(),
        teams: teams
            .iter()
            .map(|t| TeamRow {
                name: t.name.clone(),
                id: t.id.clone(),
                created_at: rfc3339(t.created_at),
                daily_quota: t.daily_quota.map_or_else(|| "the split's".to_string(), |q| format!("{q} a day")),
            })
            .collect(),
    }
    .into_response()
}

/// A team as the console lists it.
pub struct TeamRow {
    pub name: String,
    pub id: String,
    pub created_at: String,
    /// Its own limit, or that it follows the split's.
    pub daily_quota: String,
}

pub struct StageStep {
    pub name: &'static str,
    /// `done`, `current` or `todo`.
    pub status: &'static str,
}

pub struct RenderRow {
    pub subject: String,
    pub state: String,
    pub attempts: i64,
    pub worker: String,
    pub message: String,
    pub error: String,
}

#[derive(Template, WebTemplate)]
#[template(path = "admin_job.html")]
pub struct JobPage {
    pub build: BuildRow,
    pub stages: Vec<StageStep>,
    pub log: Vec<String>,
    pub error: String,
    pub renders: Vec<RenderRow>,
    pub refresh: bool,
    pub draft_exists: bool,
    /// What the build is doing, in words.
    pub status: String,
    /// Since the build was asked for (until it ended).
    pub elapsed: String,
    /// While rendering: the estimated time the render jobs left take.
    pub remaining: Option<String>,
}

/// `GET /admin/jobs/{id}`: a release build's stages and render jobs.
pub async fn job(State(state): State<AppState>, _: AdminSession, ApiPath(id): ApiPath<String>) -> Response {
    let job = match state.store.job(&id).await {
        Ok(job) if job.kind == BuildRelease::KIND => job,
        Ok(_) | Err(StoreError::NotFound) => {
            return AdminMessage::page(StatusCode::NOT_FOUND, "No such build", &format!("There is no release build job '{id}'."));
        }
        Err(e) => return AdminMessage::problem(e.into()),
    };
    let jobs = match state.store.jobs(2000).await {
        Ok(jobs) => jobs,
        Err(e) => return AdminMessage::problem(e.into()),
    };
    let progress = progress_of(&job);
    let current = progress.stage.map_or("", Stage::name);
    let at = Stage::BUILD.iter().position(|s| Some(*s) == progress.stage);
    let stages = Stage::BUILD
        .iter()
        .enumerate()
        .map(|(i, &stage)| StageStep {
            name: stage.name(),
            status: match at {
                Some(k) if i < k || (i == k && stage == Stage::Done) => "done",
                Some(k) if i == k => "current",
                _ => "todo",
            },
        })
        .collect();
    let log = progress.log.clone().unwrap_or_default();
    let mut renders: Vec<RenderRow> = jobs
        .iter()
        .filter(|j| j.kind == RenderSequence::KIND && RenderSequence::version_of_subject(&j.subject) == job.subject)
        .map(|j| {
            let progress = progress_of(j);
            RenderRow {
                subject: j.subject.clone(),
                state: j.state.to_string(),
                attempts: j.attempts,
                // The worker holding it, or the one that last reported on it.
                worker: j.lease_owner.clone().or(progress.worker).unwrap_or_default(),
                // A finished job's last progress line ("rendering camera") is history; its
                // time is from when its worker began it, not from when it was queued.
                message: match j.state {
                    JobState::Succeeded => format!("rendered in {}", duration(j.updated_at - progress.started_at.unwrap_or(j.created_at))),
                    _ => progress.message,
                },
                error: j.error.clone().unwrap_or_default(),
            }
        })
        .collect();
    renders.sort_by(|a, b| a.subject.cmp(&b.subject));
    let draft_exists = matches!(state.store.release(&job.subject).await, Ok(r) if r.state == ReleaseState::Draft);
    let build = build_row(&job, &jobs);
    let active = matches!(job.state, JobState::Queued | JobState::Running);
    let elapsed_ms = if active { crate::clock::now_ms() } else { job.updated_at } - job.created_at;
    JobPage {
        status: build_status(&job, current, &build.renders),
        elapsed: duration(elapsed_ms),
        remaining: (active && current == "rendering").then(|| remaining(elapsed_ms, &build.renders)).flatten(),
        refresh: matches!(job.state, JobState::Queued | JobState::Running),
        stages,
        log,
        error: job.error.clone().unwrap_or_default(),
        renders,
        draft_exists,
        build,
    }
    .into_response()
}

/// What a build is doing, in words: a build waiting for its render jobs is queued between
/// checks, which is not what an operator should read.
fn build_status(job: &JobRecord, stage: &str, renders: &RenderCounts) -> String {
    match (job.state, stage) {
        (JobState::Queued | JobState::Running, "rendering") if renders.total > 0 => format!(
            "rendering: {} of {} scenes done, {} rendering now{}",
            renders.succeeded,
            renders.total,
            renders.running,
            if renders.failed > 0 { format!(", {} failed", renders.failed) } else { String::new() }
        ),
        (JobState::Queued, "") => "queued: waiting for a worker".to_string(),
        (JobState::Running, "") => format!("starting (attempt {} of {})", job.attempts.max(1), job.max_attempts),
        (JobState::Queued | JobState::Running, stage) => format!("{stage} (attempt {} of {})", job.attempts.max(1), job.max_attempts),
        (state, _) => state.to_string(),
    }
}

/// The time the render jobs left should take at the pace of those done since the build began.
fn remaining(elapsed_ms: i64, renders: &RenderCounts) -> Option<String> {
    let left = renders.total.checked_sub(renders.succeeded)?;
    (renders.succeeded > 0 && left > 0).then(|| format!("about {}", duration(elapsed_ms / renders.succeeded as i64 * left as i64)))
}

/// A duration for people: `42 s`, `3 min 5 s`, `2 h 10 min`.
fn duration(ms: i64) -> String {
    let s = ms.max(0) / 1000;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {} s", s / 60, s % 60),
        _ => format!("{} h {} min", s / 3600, s % 3600 / 60),
    }
}

/// `config` with its `version = "…"` line naming the first version no entry of `taken` has:
/// its own, else its trailing number counted up (`demo-2` → `demo-3` → …), or `-2`, `-3` … added.
fn with_free_version(config: &str, taken: &std::collections::BTreeSet<String>) -> String {
    let Some(line) = config.lines().find(|l| l.trim_start().starts_with("version") && l.contains('"')) else {
        return config.to_string();
    };
    let Some(version) = line.split('"').nth(1) else { return config.to_string() };
    let digits = version.len() - version.trim_end_matches(|c: char| c.is_ascii_digit()).len();
    let (stem, first) = match version[version.len() - digits..].parse::<u64>() {
        Ok(n) if digits > 0 => (version[..version.len() - digits].to_string(), n),
        _ => (format!("{version}-"), 1),
    };
    let free = std::iter::once(version.to_string())
        .chain((first + 1..).map(|n| format!("{stem}{n}")))
        .find(|candidate| !taken.contains(candidate))
        .expect("some number is free");
    config.replacen(line, &line.replacen(version, &free, 1), 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_regeneration_form_starts_from_a_free_version() {
        let taken = |versions: &[&str]| versions.iter().map(|v| v.to_string()).collect::<std::collections::BTreeSet<_>>();
        let config = "# a comment naming version = \"x\"?\nversion = \"demo-2\"\ncreated = \"2026-11-22\"\n";
        assert_eq!(with_free_version(config, &taken(&[])), config);
        let next = with_free_version(config, &taken(&["demo-2", "demo-3"]));
        assert!(next.contains("version = \"demo-4\"\n") && next.contains("created"), "{next}");
        let plain = with_free_version("version = \"nightly\"\n", &taken(&["nightly"]));
        assert_eq!(plain, "version = \"nightly-2\"\n");
        let demo = with_free_version(crate::jobs::release_build::DEMO_CONFIG, &taken(&["demo-2"]));
        assert!(demo.contains("\nversion = \"demo-3\"") && osmab_dataset::release::config::ReleaseConfig::parse(&demo, std::path::Path::new("x")).is_ok());
    }

    #[test]
    fn durations_read_as_people_say_them() {
        assert_eq!((super::duration(42_400), super::duration(185_000), super::duration(7_800_000)), ("42 s".into(), "3 min 5 s".into(), "2 h 10 min".into()));
    }

    #[test]
    fn the_time_left_follows_the_pace_of_the_renders_done() {
        let renders = super::RenderCounts { total: 28, succeeded: 7, running: 2, failed: 0 };
        assert_eq!(super::remaining(70_000, &renders).as_deref(), Some("about 3 min 30 s"), "7 in 70 s: 21 more in 210 s");
        assert_eq!(super::remaining(70_000, &super::RenderCounts { succeeded: 0, ..renders }), None, "no pace before the first");
    }
}
