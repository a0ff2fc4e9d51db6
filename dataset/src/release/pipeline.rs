//! The scenes of a release built several at a time. One thread settles the scenes in
//! order (a scene's candidate prompts depend on what the scenes before it took), while
//! [`scenes_at_once`] workers each take the next settled scene through everything that
//! depends on it alone: its sequences, ground truth, questions and quality. A scene in a
//! stretch of serial work (its ground truth, its questions) leaves the cores to the
//! others' rendering, and on many cores several scenes render side by side.
//!
//! Each worker (and the settling thread) has a pool of its own, as large as the caller's:
//! a scene in a serial stretch leaves the cores to the other scenes' pools, and the last
//! scene of a build has every core. (One shared pool serialises them instead: a thread
//! waiting inside one scene's parallel loop takes up another whole scene and finishes it
//! first.) A build inside a one-thread pool runs one scene after another; a scene's
//! output depends on its inputs alone, so the release is the same to the byte on any
//! number of threads.

use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, mpsc};

use osmab_evaluator::{InputError, Result};

/// Scenes in flight at once on `threads` threads: one on one thread (a sequential build);
/// else half as many as threads, at least two (one renders while the other is in a serial
/// stretch) and at most eight (each holds its world and frame buffers: a few hundred MB
/// at 1200×680).
pub fn scenes_at_once(threads: usize) -> usize {
    if threads <= 1 { 1 } else { (threads / 2).clamp(2, 8) }
}

/// The variable that sets how many scenes a build assembles at once instead of
/// [`scenes_at_once`] (for measuring; a release's bytes do not depend on it).
pub const SCENES_AT_ONCE_VARIABLE: &str = "OSMAB_RELEASE_SCENES_AT_ONCE";

/// Scenes in flight at once on `threads` threads: [`SCENES_AT_ONCE_VARIABLE`] when set, else
/// [`scenes_at_once`].
fn scenes_in_flight(threads: usize) -> Result<usize> {
    scenes_in_flight_given(std::env::var(SCENES_AT_ONCE_VARIABLE).ok().as_deref(), threads)
}

/// Scenes in flight at once on `threads` threads when [`SCENES_AT_ONCE_VARIABLE`] is `given`
/// (a whole number of at least 1).
fn scenes_in_flight_given(given: Option<&str>, threads: usize) -> Result<usize> {
    let Some(text) = given else { return Ok(scenes_at_once(threads)) };
    text.trim()
        .parse::<usize>()
        .ok()
        .filter(|n| *n >= 1)
        .ok_or_else(|| InputError::new(SCENES_AT_ONCE_VARIABLE, "(environment)", format!("expected a whole number of scenes of at least 1, found {text:?}")))
}

/// `assemble` every scene of `0..count` once `settle` (called in order, one scene at a
/// time) has settled it; returns what `assemble` made of each, in order. Both report
/// through `say`, whose lines reach `progress` on the calling thread. The first scene
/// that fails (settling or assembling) stops the build: no scene after it is started, the
/// ones in flight finish (their stages stay for a resumed build), and the error of the
/// lowest failed scene is returned, as a build of one scene at a time would return it.
pub fn assemble_in_order<S: Send, T: Send>(
    count: usize,
    settle: impl Fn(usize, &dyn Fn(&str)) -> Result<S> + Sync,
    assemble: impl Fn(usize, S, &dyn Fn(&str)) -> Result<T> + Sync,
    progress: &dyn Fn(&str),
) -> Result<Vec<T>> {
    let threads = rayon::current_num_threads();
    let workers = scenes_in_flight(threads)?.min(count.max(1));
    let settling_pool = pool(threads, "settle")?;
    let worker_pools: Vec<rayon::ThreadPool> = (0..workers).map(|_| pool(threads, "scene")).collect::<Result<_>>()?;
    let outcomes = Outcomes::new(count);
    // At most one settled scene waits for each worker.
    let (settled_tx, settled_rx) = mpsc::sync_channel::<(usize, S)>(workers);
    let settled_rx = Mutex::new(settled_rx);
    let (say_tx, say_rx) = mpsc::channel::<String>();
    std::thread::scope(|scope| {
        let (say, outcomes, settle) = (say_tx.clone(), &outcomes, &settle);
        scope.spawn(move || {
            let say = |line: &str| drop(say.send(line.to_owned()));
            outcomes.settle_in_order(&settling_pool, settle, &settled_tx, &say);
        });
        for pool in &worker_pools {
            let (say, settled_rx, assemble) = (say_tx.clone(), &settled_rx, &assemble);
            scope.spawn(move || {
                let say = |line: &str| drop(say.send(line.to_owned()));
                outcomes.assemble_settled(pool, assemble, settled_rx, &say);
            });
        }
        drop(say_tx);
        for line in say_rx {
            progress(&line);
        }
    });
    outcomes.into_scenes()
}

/// A pool of `threads` threads named for their `role`.
fn pool(threads: usize, role: &'static str) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(move |i| format!("release-{role}-{i}"))
        .build()
        .map_err(|e| InputError::new("(release build)", "threads", format!("cannot start {threads} threads: {e}")))
}

/// What became of every scene, shared by the threads of a build.
struct Outcomes<T> {
    /// Set by the first failure (or panic): no scene is started after it.
    failed: AtomicBool,
    results: Mutex<Vec<Option<Result<T>>>>,
    /// A worker that panics keeps draining the queue like the others (else the settling
    /// thread could wait on a full queue for ever); the panic is raised again at the end.
    panicked: Mutex<Option<Box<dyn std::any::Any + Send>>>,
}

impl<T: Send> Outcomes<T> {
    fn new(count: usize) -> Self {
        Self { failed: AtomicBool::new(false), results: Mutex::new((0..count).map(|_| None).collect()), panicked: Mutex::new(None) }
    }

    fn failed(&self) -> bool {
        self.failed.load(Ordering::SeqCst)
    }

    fn record(&self, index: usize, result: Result<T>) {
        if result.is_err() {
            self.failed.store(true, Ordering::SeqCst);
        }
        self.results.lock().expect("no thread panics holding the results")[index] = Some(result);
    }

    /// The settling thread: every scene in order onto the queue, until one fails.
    fn settle_in_order<S: Send>(
        &self,
        pool: &rayon::ThreadPool,
        settle: impl Fn(usize, &dyn Fn(&str)) -> Result<S> + Sync,
        queue: &mpsc::SyncSender<(usize, S)>,
        say: &(dyn Fn(&str) + Sync),
    ) {
        let count = self.results.lock().expect("no thread panics holding the results").len();
        for index in 0..count {
            if self.failed() {
                return;
            }
            match pool.install(|| settle(index, say)) {
                Ok(settled) => {
                    if queue.send((index, settled)).is_err() {
                        return;
                    }
                }
                Err(e) => return self.record(index, Err(e)),
            }
        }
    }

    /// A worker: the next settled scene from the queue, assembled on its own `pool`,
    /// until the queue ends. After a failure the queue is drained, so the settling thread
    /// never waits on it.
    fn assemble_settled<S: Send>(
        &self,
        pool: &rayon::ThreadPool,
        assemble: impl Fn(usize, S, &dyn Fn(&str)) -> Result<T> + Sync,
        queue: &Mutex<mpsc::Receiver<(usize, S)>>,
        say: &(dyn Fn(&str) + Sync),
    ) {
        loop {
            let next = queue.lock().expect("no thread panics holding the queue").recv();
            let Ok((index, settled)) = next else { return };
            if self.failed() {
                continue;
            }
            match std::panic::catch_unwind(AssertUnwindSafe(|| pool.install(|| assemble(index, settled, say)))) {
                Ok(result) => self.record(index, result),
                Err(panic) => {
                    self.failed.store(true, Ordering::SeqCst);
                    self.panicked.lock().expect("no thread panics holding it").get_or_insert(panic);
                }
            }
        }
    }

    /// Every scene in order, or the error of the lowest failed one; a panic (a bug, not a
    /// failed scene) goes on as a panic, once every thread has stopped.
    fn into_scenes(self) -> Result<Vec<T>> {
        if let Some(panic) = self.panicked.into_inner().expect("every thread has ended") {
            std::panic::resume_unwind(panic);
        }
        let results = self.results.into_inner().expect("every thread has ended");
        let mut scenes = Vec::with_capacity(results.len());
        for result in results {
            match result {
                Some(Ok(scene)) => scenes.push(scene),
                Some(Err(e)) => return Err(e),
                None => {}
            }
        }
        Ok(scenes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scenes_at_once_are_the_builds_choice_unless_the_variable_names_a_whole_number() {
        assert_eq!(scenes_in_flight_given(None, 1).unwrap(), 1);
        assert_eq!(scenes_in_flight_given(None, 16).unwrap(), 8);
        assert_eq!(scenes_in_flight_given(Some(" 3 "), 16).unwrap(), 3);
        for wrong in ["0", "-2", "two", ""] {
            let err = scenes_in_flight_given(Some(wrong), 16).unwrap_err().to_string();
            assert!(err.contains(SCENES_AT_ONCE_VARIABLE) && err.contains("whole number"), "{wrong:?}: {err}");
        }
    }

    fn on_threads<R: Send>(threads: usize, work: impl FnOnce() -> R + Send) -> R {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(work)
    }

    #[test]
    fn scenes_come_back_in_order_with_every_line_said_whatever_the_threads() {
        for threads in [1, 2, 5] {
            let lines = Mutex::new(Vec::new());
            let scenes = on_threads(threads, || {
                assemble_in_order(
                    9,
                    |i, say| {
                        say(&format!("settled {i}"));
                        Ok(i * 10)
                    },
                    |i, settled, say| {
                        // Later scenes finish first when several are in flight.
                        std::thread::sleep(std::time::Duration::from_millis(((9 - i) * 3) as u64));
                        say(&format!("assembled {i}"));
                        Ok(format!("scene {i} from {settled}"))
                    },
                    &|line| lines.lock().unwrap().push(line.to_string()),
                )
            })
            .unwrap();
            assert_eq!(scenes, (0..9).map(|i| format!("scene {i} from {}", i * 10)).collect::<Vec<_>>(), "{threads} threads");
            let lines = lines.into_inner().unwrap();
            assert_eq!(lines.len(), 18, "{lines:?}");
            let settled: Vec<&String> = lines.iter().filter(|l| l.starts_with("settled")).collect();
            assert_eq!(settled, (0..9).map(|i| format!("settled {i}")).collect::<Vec<_>>().iter().collect::<Vec<_>>(), "settled in order");
        }
    }

    #[test]
    fn a_scene_that_panics_panics_the_build_instead_of_hanging_it() {
        for threads in [1, 4] {
            let (done_tx, done_rx) = mpsc::channel();
            std::thread::spawn(move || {
                let outcome = std::panic::catch_unwind(|| {
                    on_threads(threads, || assemble_in_order(6, |i, _| Ok(i), |i, _, _| if i == 0 { panic!("a bug in scene 0") } else { Ok(i) }, &|_| {}))
                });
                let message = outcome.err().and_then(|p| p.downcast_ref::<&str>().map(|m| m.to_string()));
                done_tx.send(message).unwrap();
            });
            let message = done_rx.recv_timeout(std::time::Duration::from_secs(60)).expect("the build ends");
            assert_eq!(message.as_deref(), Some("a bug in scene 0"), "{threads} threads");
        }
    }

    #[test]
    fn the_lowest_failed_scene_stops_the_build_and_nothing_after_it_starts() {
        for threads in [1, 4] {
            let started = Mutex::new(Vec::new());
            let err = on_threads(threads, || {
                assemble_in_order(
                    12,
                    |i, _| if i == 9 { Err(InputError::new("scene_009", "quality", "no prompt settles")) } else { Ok(i) },
                    |i, _, _| {
                        started.lock().unwrap().push(i);
                        std::thread::sleep(std::time::Duration::from_millis(if i == 3 { 40 } else { 1 }));
                        if i == 3 || i == 5 { Err(InputError::new(format!("scene_00{i}"), "render", "failed")) } else { Ok(i) }
                    },
                    &|_| {},
                )
            })
            .unwrap_err();
            assert_eq!(err.file, "scene_003", "{threads} threads: {err}");
            let started = started.into_inner().unwrap();
            assert!(started.iter().all(|&i| i < 9), "{threads} threads: nothing after a failure starts: {started:?}");
            assert!(started.contains(&3), "{started:?}");
        }
    }
}
