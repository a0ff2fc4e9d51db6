//! A command whose output's reader went away (`osmab client leaderboard | head -3`) stops
//! quietly, as Unix tools stopped by SIGPIPE do.

/// The exit status of a command whose reader went away: 128 + SIGPIPE, what a shell
/// reports for a Unix tool the signal stopped.
const CLOSED_STDOUT_STATUS: i32 = 141;

/// A command whose output's reader went away (`osmab client leaderboard | head -3`) stops
/// quietly, as Unix tools stopped by SIGPIPE do. Rust ignores SIGPIPE (so the service's
/// sockets report a closed peer as an error) and `println!` panics on the broken pipe
/// instead; that panic, and only that one, ends the process without a panic message.
pub fn stop_quietly_when_stdout_closes() {
    let report = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info.payload().downcast_ref::<String>().map(String::as_str).or_else(|| info.payload().downcast_ref::<&str>().copied());
        if message.is_some_and(is_closed_stdout) {
            std::process::exit(CLOSED_STDOUT_STATUS);
        }
        report(info);
    }));
}

/// Whether a panic message is `print!`'s on a standard output whose reader is gone.
fn is_closed_stdout(message: &str) -> bool {
    message.starts_with("failed printing to stdout") && message.contains("Broken pipe")
}
