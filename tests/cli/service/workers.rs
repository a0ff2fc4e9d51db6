//! The queue never loses work: a worker that dies mid-job has its job finished by
//! another once the lease expires, and a submission accepted before a shutdown is scored
//! after the restart.

use std::process::Command;
use std::time::{Duration, Instant};

use serde_json::Value;

use super::{Backend, Deployment, baseline_dir, on_both_backends, tar_of};

pub(super) fn signal(child: &std::process::Child, name: &str) {
    let status = Command::new("kill").args([&format!("-{name}"), &child.id().to_string()]).status().unwrap();
    assert!(status.success());
}

pub(super) fn job_of(server: &super::Server<'_>, submission: &str) -> Value {
    let view = server.admin(server.get(&format!("/api/v1/submissions/{submission}"))).json::<Value>().unwrap();
    let id = view["jobs"][0]["id"].as_str().unwrap().to_string();
    server.admin(server.get(&format!("/api/v1/jobs/{id}"))).json().unwrap()
}

/// Start a worker named `name`, and `kill -9` it the moment it holds the job of submission
/// `id`; false when the job finished before the kill could land (try again).
pub(super) fn killed_holding_the_job(deployment: &Deployment, server: &super::Server<'_>, id: &str, name: &str) -> bool {
    let mut worker = deployment.spawn(&["worker"], name);
    let started = Instant::now();
    let caught = loop {
        match job_of(server, id)["state"].as_str().unwrap() {
            "running" => {
                signal(&worker, "KILL");
                let _ = worker.wait();
                break job_of(server, id)["state"] == "running";
            }
            "succeeded" => break false,
            _ => {}
        }
        assert!(started.elapsed() < Duration::from_secs(60), "{name} never claimed the job: {}", deployment.log(name));
        std::thread::sleep(Duration::from_millis(1));
    };
    if !caught {
        let _ = worker.kill();
        let _ = worker.wait();
    }
    caught
}

fn a_dead_worker_s_job_is_finished_by_another(backend: Backend) {
    let deployment = Deployment::new(backend, &[("OSMAB_WORKERS", "0"), ("OSMAB_JOB_LEASE_SECS", "2"), ("OSMAB_POLL_MS", "20")]);
    let server = deployment.serve();
    server.import_test_release();
    let token = server.team("Team Workers");
    let archive = tar_of(baseline_dir("label-noise").path());
    // Worker A must be killed mid-job; a job that finishes first is tried again. (A
    // frozen process would not do on SQLite: it can hold the database's write lock.)
    for attempt in 0..5 {
        let id = server.upload(&token, &archive, "").json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
        if !killed_holding_the_job(&deployment, &server, &id, &format!("worker-a{attempt}")) {
            continue;
        }
        // Worker A died holding the lease; worker B takes over once it expires.
        let mut second = deployment.spawn(&["worker"], &format!("worker-b{attempt}"));
        let done = server.wait_done(&id, &token);
        assert_eq!(done["state"], "scored", "{done}");
        let job = job_of(&server, &id);
        assert_eq!((job["state"].as_str(), job["attempts"].as_i64()), (Some("succeeded"), Some(2)), "{job}");
        assert_eq!(done["score_history"].as_array().unwrap().len(), 1, "one score, not two");
        // Worker B's start swept what the killed worker A left in its scratch directory.
        let leftovers: Vec<_> = std::fs::read_dir(deployment.data.path().join("blobs/.incoming"))
            .unwrap()
            .flatten()
            .filter(|e| e.path().is_dir())
            .flat_map(|d| std::fs::read_dir(d.path()).unwrap().flatten().map(|f| f.path()))
            .collect();
        assert!(leftovers.is_empty(), "scratch left after kill -9: {leftovers:?}");
        // The history says why it was scored twice.
        let retried = done["history"].as_array().unwrap().iter().filter(|e| e["state"] == "scoring").last().cloned().unwrap_or_default();
        assert!(retried["reason"].as_str().is_some_and(|r| r.contains("attempt 2") && r.contains("stopped responding")), "{done}");
        // B stops gracefully on SIGTERM.
        signal(&second, "TERM");
        assert!(second.wait().unwrap().success(), "{}", deployment.log(&format!("worker-b{attempt}")));
        return;
    }
    panic!("the job finished before worker A could be stopped, five times");
}

on_both_backends!(a_job_whose_worker_died_is_finished_by_another_worker, super::a_dead_worker_s_job_is_finished_by_another);

fn accepted_work_survives_a_restart(backend: Backend) {
    let deployment = Deployment::new(backend, &[("OSMAB_WORKERS", "0")]);
    let token;
    let id;
    {
        let mut server = deployment.serve();
        server.import_test_release();
        token = server.team("Team Restart");
        let accepted = server.upload(&token, &tar_of(baseline_dir("oracle").path()), "");
        assert_eq!(accepted.status(), 202);
        id = accepted.json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
        signal(&server.child, "TERM");
        assert!(server.child.wait().unwrap().success(), "serve stops cleanly on SIGTERM: {}", deployment.log("serve"));
    }
    let server = deployment.serve();
    let waiting: Value = server.get(&format!("/api/v1/submissions/{id}")).bearer_auth(&token).send().unwrap().json().unwrap();
    assert_eq!(waiting["state"], "queued", "still queued, not lost");
    let mut worker = deployment.spawn(&["worker"], "worker");
    assert_eq!(server.wait_done(&id, &token)["state"], "scored");
    signal(&worker, "TERM");
    assert!(worker.wait().unwrap().success());
}

on_both_backends!(a_submission_accepted_before_a_restart_is_scored_after_it, super::accepted_work_survives_a_restart);

fn queued_submissions_show_their_place_and_an_estimate(backend: Backend) {
    let deployment = Deployment::new(backend, &[("OSMAB_WORKERS", "0"), ("OSMAB_POLL_MS", "20")]);
    let server = deployment.serve();
    server.import_test_release();
    let token = server.team("Team Queue");
    let upload = |name: &str| {
        let accepted = server.upload(&token, &tar_of(baseline_dir(name).path()), "");
        assert_eq!(accepted.status(), 202);
        accepted.json::<Value>().unwrap()["id"].as_str().unwrap().to_string()
    };
    let view = |id: &str| -> Value { server.get(&format!("/api/v1/submissions/{id}")).bearer_auth(&token).send().unwrap().json().unwrap() };
    let (first, second) = (upload("oracle"), upload("merge"));

    // Nothing scored yet on this server: a place, no estimate.
    assert_eq!(view(&first)["queue"], serde_json::json!({"ahead": 0, "based_on": 0, "position": 1}));
    assert_eq!(view(&second)["queue"], serde_json::json!({"ahead": 1, "based_on": 0, "position": 2}));
    let page = server.get(&format!("/submissions/{second}")).bearer_auth(&token).send().unwrap().text().unwrap();
    assert!(page.contains("Position 2 in the queue (1 job ahead); no estimate yet"), "{page}");

    // Once scorings have been measured, the next one in the queue gets an estimate.
    let mut worker = deployment.spawn(&["worker"], "worker");
    for id in [&first, &second] {
        assert_eq!(server.wait_done(id, &token)["state"], "scored");
        assert!(view(id).get("queue").is_none(), "a scored submission is in no queue");
    }
    signal(&worker, "TERM");
    assert!(worker.wait().unwrap().success());
    let third = upload("label-noise");
    let queued = view(&third);
    let queue = &queued["queue"];
    assert_eq!((queue["position"].as_i64(), queue["based_on"].as_i64()), (Some(1), Some(2)), "{queued}");
    assert!(queue["median_scoring_seconds"].as_f64().is_some_and(|s| s > 0.0), "{queue}");
    let (start, done) = (queue["estimated_start_at"].as_str().unwrap(), queue["estimated_done_at"].as_str().unwrap());
    assert!(start <= done, "{queue}");
    let document: Value = server.get("/api/v1/openapi.json").send().unwrap().json().unwrap();
    let broken = super::schema::violations(&document, super::schema::response_schema(&document, "get", "/api/v1/submissions/{id}"), &queued);
    assert!(broken.is_empty(), "{broken:?}");
    let page = server.get(&format!("/submissions/{third}")).bearer_auth(&token).send().unwrap().text().unwrap();
    assert!(page.contains("Next in the queue; expected to finish around"), "{page}");
}

on_both_backends!(a_queued_submission_shows_its_place_and_an_estimated_end, super::queued_submissions_show_their_place_and_an_estimate);

fn a_submission_whose_workers_died_refunds_its_quota(backend: Backend) {
    let deployment =
        Deployment::new(backend, &[("OSMAB_WORKERS", "0"), ("OSMAB_JOB_LEASE_SECS", "2"), ("OSMAB_JOB_MAX_ATTEMPTS", "1"), ("OSMAB_POLL_MS", "20")]);
    let server = deployment.serve();
    server.import_test_release();
    let token = server.team("Team Refund");
    let used = || server.get("/api/v1/me").bearer_auth(&token).send().unwrap().json::<Value>().unwrap()["quota"]["used"].as_i64().unwrap();
    // Worker A is killed while it holds the job; with one attempt allowed, worker B fails
    // the job once A's lease expires — no fault of the team's. A job that finishes in the
    // instant before the kill is tried again with another archive.
    for (attempt, name) in ["drop-small", "label-noise", "pose-drift"].into_iter().enumerate() {
        let before = used();
        let id = server.upload(&token, &tar_of(baseline_dir(name).path()), "").json::<Value>().unwrap()["id"].as_str().unwrap().to_string();
        assert_eq!(used(), before + 1);
        if !killed_holding_the_job(&deployment, &server, &id, &format!("worker-a{attempt}")) {
            continue;
        }
        let mut second = deployment.spawn(&["worker"], &format!("worker-b{attempt}"));
        let done = server.wait_done(&id, &token);
        assert_eq!(done["state"], "failed", "{done}");
        assert_eq!(done["quota_refunded"], true, "{done}");
        assert!(done["reason"].as_str().is_some_and(|r| r.contains("stopped responding") && r.contains("does not count against the team's quota")), "{done}");
        assert_eq!(used(), before, "the quota unit is back");
        signal(&second, "TERM");
        assert!(second.wait().unwrap().success());
        return;
    }
    panic!("the job finished before worker A could be killed, three times");
}

on_both_backends!(a_submission_failed_by_dying_workers_gives_its_quota_back, super::a_submission_whose_workers_died_refunds_its_quota);
