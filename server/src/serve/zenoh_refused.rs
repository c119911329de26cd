//! Counting the puts that Zenoh's access control refuses at the server.
//!
//! A put the rules refuse is dropped by Zenoh's ingress interceptor (zenoh 1.10,
//! `net/routing/interceptor/access_control.rs`) before any subscriber of the server sees it, so
//! the engine's input checks never count it. Zenoh counts such drops only when built with its
//! `stats` feature (the server's `zenoh` cargo feature turns it on): per transport, as the
//! histogram `zenoh_rx_network_message_dropped_payload_bytes` with the labels
//! `message="put"` and `reason="access-control"`, whose `_count` samples are the number of
//! refused messages. It is read through the server session's own adminspace
//! (`@/<zid>/<whatami>/metrics`, Prometheus/OpenMetrics text).
//!
//! So when the Zenoh configuration enables access control, [`enable_adminspace`] turns the
//! adminspace on (read only for the server's own session: the access-control rules are applied
//! to every message a remote peer sends, queries on `@/**` included, and the shipped rules refuse
//! them), and [`RefusedPuts`] runs a thread that queries the metrics every [`PERIOD`] and hands
//! the growth of the count to the loop ([`RefusedPuts::take`]: one atomic swap, nothing
//! allocated on the step path). The loop adds it to `inputs_rejected[other]`.
//!
//! What it counts: every put a remote peer sent to the server that the rules refused, on any
//! key. The metric has no key label; with the shipped rules a peer's puts reach the server only on
//! keys the server subscribes to (`pivotsim/<world>/cmd/**`), but a peer that publishes elsewhere
//! to the server is counted too. Deletes, refused queries (those get no reply, which the querier
//! sees) and the server's own refused egress messages are not counted. Counts of a peer that
//! disconnected stay in the total (`disconnected=true`), so the total never shrinks; if it ever
//! did, nothing is counted until it grows past its largest value again (a refused put is never
//! counted twice).

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{RecvTimeoutError, Sender, channel};
use std::thread::JoinHandle;
use std::time::Duration;

use tracing::warn;
use zenoh::Wait;

/// How often the thread reads the metrics: a refused put shows in the stats frame within about
/// this long (plus one step).
pub const PERIOD: Duration = Duration::from_millis(500);

/// How long one read of the server's own metrics may take (a local query: well under 1 ms).
pub const QUERY_TIMEOUT: Duration = Duration::from_millis(400);

/// The histogram family of messages dropped on reception (zenoh-stats 1.10: registry prefix
/// `zenoh`, name `rx_network_message_dropped_payload`, unit bytes).
pub const DROPPED_FAMILY: &str = "zenoh_rx_network_message_dropped_payload_bytes";

/// When `config` enables Zenoh's access control: enables the adminspace with read permission
/// (for the reader thread) and returns the session's mode (`peer`, `router` or `client`: the
/// `<whatami>` of its adminspace keys); `None` without access control. The write permission is
/// left as the configuration has it (off by default).
pub fn enable_adminspace(config: &mut zenoh::Config) -> Result<Option<String>, String> {
    let enabled = config.get_json("access_control/enabled").map_err(|e| e.to_string())?;
    if enabled.trim() != "true" {
        return Ok(None);
    }
    for (key, value) in [("adminspace/enabled", "true"), ("adminspace/permissions/read", "true")] {
        config.insert_json5(key, value).map_err(|e| format!("{key}: {e}"))?;
    }
    // A configuration without a mode opens a peer.
    let mode = config.get_json("mode").map_err(|e| e.to_string())?;
    let mode = match mode.trim().trim_matches('"') {
        m @ ("peer" | "router" | "client") => m.to_string(),
        _ => "peer".to_string(),
    };
    Ok(Some(mode))
}

/// The number of puts refused by access control in a metrics text: the sum of the `_count`
/// samples of [`DROPPED_FAMILY`] labelled `message="put"` and `reason="access-control"`.
/// `None` when the text does not describe that family at all (Zenoh built without `stats`).
pub fn refused_puts(text: &str) -> Option<u64> {
    let count_name = format!("{DROPPED_FAMILY}_count");
    let mut described = false;
    let mut total = 0u64;
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("# TYPE ") {
            described |= rest.split_whitespace().next() == Some(DROPPED_FAMILY);
            continue;
        }
        if line.starts_with('#') {
            continue;
        }
        let Some((name, labels, value)) = sample(line) else { continue };
        if name != count_name {
            continue;
        }
        if label(labels, "message") == Some("put") && label(labels, "reason") == Some("access-control") {
            total = total.saturating_add(value);
        }
    }
    described.then_some(total)
}

/// A sample line `name{labels} value [timestamp]` split into its name, label block (without the
/// braces; empty when there is none) and integer value; `None` for anything else.
fn sample(line: &str) -> Option<(&str, &str, u64)> {
    let (name, labels, rest) = match line.find('{') {
        Some(open) => {
            let close = closing_brace(line, open)?;
            (&line[..open], &line[open + 1..close], &line[close + 1..])
        }
        None => {
            let (name, rest) = line.split_once(' ')?;
            (name, "", rest)
        }
    };
    let value = rest.split_whitespace().next()?;
    // Counts are integers; a count written as a float (`3.0`) is read if it is a whole number.
    let value = value.parse::<u64>().ok().or_else(|| {
        let v = value.parse::<f64>().ok()?;
        (v.is_finite() && v >= 0.0 && v.fract() == 0.0 && v < u64::MAX as f64).then_some(v as u64)
    })?;
    Some((name, labels, value))
}

/// The index of the `}` that closes the label block opened at `open` (quoted values may hold
/// braces and escaped quotes).
fn closing_brace(line: &str, open: usize) -> Option<usize> {
    let mut quoted = false;
    let mut escaped = false;
    for (i, c) in line[open + 1..].char_indices() {
        match (quoted, escaped, c) {
            (true, true, _) => escaped = false,
            (true, false, '\\') => escaped = true,
            (true, false, '"') => quoted = false,
            (false, _, '"') => quoted = true,
            (false, _, '}') => return Some(open + 1 + i),
            _ => {}
        }
    }
    None
}

/// The value of label `key` in a label block (`a="x",b="y"`), unescaped values compared as they
/// are written (the labels this module reads have plain values).
fn label<'a>(labels: &'a str, key: &str) -> Option<&'a str> {
    let mut rest = labels;
    while !rest.is_empty() {
        let (k, after) = rest.split_once("=\"")?;
        let mut end = None;
        let mut escaped = false;
        for (i, c) in after.char_indices() {
            match (escaped, c) {
                (true, _) => escaped = false,
                (false, '\\') => escaped = true,
                (false, '"') => {
                    end = Some(i);
                    break;
                }
                _ => {}
            }
        }
        let end = end?;
        if k.trim().trim_start_matches(',').trim() == key {
            return Some(&after[..end]);
        }
        rest = &after[end + 1..];
    }
    None
}

/// The reader thread and the count it hands to the loop.
#[derive(Debug)]
pub struct RefusedPuts {
    pending: Arc<AtomicU64>,
    stop: Option<Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

impl RefusedPuts {
    /// Starts the thread that reads `session`'s own metrics every [`PERIOD`] (`whatami`: its
    /// mode, from [`enable_adminspace`]).
    pub fn spawn(session: zenoh::Session, whatami: &str) -> std::io::Result<RefusedPuts> {
        let pending = Arc::new(AtomicU64::new(0));
        let (stop, stopped) = channel::<()>();
        let selector = format!(
            "@/{}/{whatami}/metrics?per_transport=false;per_link=false;per_key=false;disconnected=true;compression=false",
            session.zid()
        );
        let shared = pending.clone();
        let thread = std::thread::Builder::new().name("zenoh-acl-count".into()).spawn(move || {
            let mut counted = 0u64;
            let mut failures = 0u64;
            loop {
                match stopped.recv_timeout(PERIOD) {
                    Err(RecvTimeoutError::Timeout) => {}
                    Ok(()) | Err(RecvTimeoutError::Disconnected) => return,
                }
                match read(&session, &selector) {
                    Ok(total) => {
                        if total > counted {
                            shared.fetch_add(total - counted, Ordering::Relaxed);
                            counted = total;
                        }
                    }
                    Err(e) => {
                        if failures.is_multiple_of(100) {
                            warn!(
                                "zenoh: cannot read the access-control drop count ({e}; {} failures so far): puts refused meanwhile are counted when a read succeeds",
                                failures + 1
                            );
                        }
                        failures += 1;
                    }
                }
            }
        })?;
        Ok(RefusedPuts { pending, stop: Some(stop), thread: Some(thread) })
    }

    /// Puts refused since the last call.
    pub fn take(&self) -> u64 {
        self.pending.swap(0, Ordering::Relaxed)
    }
}

impl Drop for RefusedPuts {
    /// Stops the thread (at most one query's wait).
    fn drop(&mut self) {
        drop(self.stop.take());
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// One read of the session's metrics: the refused-put total.
fn read(session: &zenoh::Session, selector: &str) -> Result<u64, String> {
    let replies = session.get(selector).timeout(QUERY_TIMEOUT).wait().map_err(|e| e.to_string())?;
    let reply = replies
        .recv_timeout(QUERY_TIMEOUT + Duration::from_millis(100))
        .map_err(|e| e.to_string())?
        .ok_or("no reply from the adminspace")?;
    let sample = reply.result().map_err(|e| format!("an error reply: {:?}", e.payload().to_bytes()))?;
    let bytes = sample.payload().to_bytes();
    let text = std::str::from_utf8(&bytes).map_err(|_| "the metrics are not text (compressed?)")?;
    refused_puts(text).ok_or_else(|| format!("no `{DROPPED_FAMILY}` in the metrics (zenoh without `stats`?)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Written after the shape of zenoh 1.10's output for 10 refused puts (seen from a test
    /// server: the `_count` and `_sum` lines, labels `local_id`, `local_whatami`, `priority`,
    /// `message`, `protocol=""`, `reason`), with samples added that must not count (another
    /// priority counts; a congestion drop, a refused query and tx drops do not).
    const TEXT: &str = concat!(
        "# HELP zenoh_build Zenoh build version.\n",
        "# TYPE zenoh_build info\n",
        "zenoh_build_info{local_id=\"ab\",local_whatami=\"peer\",version=\"v1\"} 1\n",
        "# HELP zenoh_rx_network_message_dropped_payload_bytes Histogram.\n",
        "# TYPE zenoh_rx_network_message_dropped_payload_bytes histogram\n",
        "# UNIT zenoh_rx_network_message_dropped_payload_bytes bytes\n",
        "zenoh_rx_network_message_dropped_payload_bytes_sum{local_id=\"ab\",local_whatami=\"peer\",priority=\"data\",message=\"put\",protocol=\"\",reason=\"access-control\"} 480.0\n",
        "zenoh_rx_network_message_dropped_payload_bytes_count{local_id=\"ab\",local_whatami=\"peer\",priority=\"data\",message=\"put\",protocol=\"\",reason=\"access-control\"} 10\n",
        "zenoh_rx_network_message_dropped_payload_bytes_bucket{local_id=\"ab\",local_whatami=\"peer\",priority=\"data\",message=\"put\",protocol=\"\",reason=\"access-control\",le=\"+Inf\"} 10\n",
        "zenoh_rx_network_message_dropped_payload_bytes_count{local_id=\"ab\",local_whatami=\"peer\",priority=\"data_high\",message=\"put\",protocol=\"\",reason=\"access-control\"} 2\n",
        "zenoh_rx_network_message_dropped_payload_bytes_count{local_id=\"ab\",local_whatami=\"peer\",priority=\"data\",message=\"put\",protocol=\"\",reason=\"congestion\"} 7\n",
        "zenoh_rx_network_message_dropped_payload_bytes_count{local_id=\"ab\",local_whatami=\"peer\",priority=\"data\",message=\"query\",reason=\"access-control\"} 3\n",
        "# TYPE zenoh_tx_network_message_dropped_payload_bytes histogram\n",
        "zenoh_tx_network_message_dropped_payload_bytes_count{local_id=\"ab\",local_whatami=\"peer\",priority=\"data\",message=\"put\",protocol=\"\",reason=\"access-control\"} 5\n",
        "# EOF\n",
    );

    #[test]
    fn counts_ingress_puts_refused_by_access_control_only() {
        assert_eq!(refused_puts(TEXT), Some(12));
    }

    #[test]
    fn a_described_family_without_samples_is_zero_and_no_family_is_none() {
        let empty = "# TYPE zenoh_rx_network_message_dropped_payload_bytes histogram\n# EOF\n";
        assert_eq!(refused_puts(empty), Some(0));
        let no_stats = "# TYPE zenoh_build info\nzenoh_build_info{version=\"v1\"} 1\n# EOF\n";
        assert_eq!(refused_puts(no_stats), None);
        assert_eq!(refused_puts(""), None);
    }

    #[test]
    fn labels_with_braces_quotes_and_commas_in_values_are_read() {
        let text = concat!(
            "# TYPE zenoh_rx_network_message_dropped_payload_bytes histogram\n",
            "zenoh_rx_network_message_dropped_payload_bytes_count{remote_cn=\"a}b,\\\"c\",message=\"put\",reason=\"access-control\"} 4 1700000000\n",
            "zenoh_rx_network_message_dropped_payload_bytes_count{message=\"put\",reason=\"access-control\"} 5.0\n",
        );
        assert_eq!(refused_puts(text), Some(9));
    }

    #[test]
    fn garbage_never_panics_and_is_not_counted() {
        let family = "# TYPE zenoh_rx_network_message_dropped_payload_bytes histogram\n";
        for bad in [
            "zenoh_rx_network_message_dropped_payload_bytes_count{message=\"put\",reason=\"access-control\" 4",
            "zenoh_rx_network_message_dropped_payload_bytes_count{message=\"put,reason=\"access-control\"} 4",
            "zenoh_rx_network_message_dropped_payload_bytes_count{message=\"put\",reason=\"access-control\"} -4",
            "zenoh_rx_network_message_dropped_payload_bytes_count{message=\"put\",reason=\"access-control\"} NaN",
            "zenoh_rx_network_message_dropped_payload_bytes_count{message=\"put\",reason=\"access-control\"} 1e400",
            "zenoh_rx_network_message_dropped_payload_bytes_count{message=\"put\",reason=\"access-control\"}",
            "zenoh_rx_network_message_dropped_payload_bytes_count{message=\"put\",reason=\"access-control\"} 2.5",
            "zenoh_rx_network_message_dropped_payload_bytes_count{{{{",
            "{\"\\",
            "\u{feff}é{ü=\"",
        ] {
            assert_eq!(refused_puts(&format!("{family}{bad}\n")), Some(0), "{bad}");
        }
        let big = "zenoh_rx_network_message_dropped_payload_bytes_count{message=\"put\",reason=\"access-control\"} 18446744073709551615\n";
        assert_eq!(refused_puts(&format!("{family}{big}{big}")), Some(u64::MAX), "saturates");
    }

    #[test]
    fn the_adminspace_is_enabled_only_with_access_control() {
        let mut c = zenoh::Config::default();
        assert_eq!(enable_adminspace(&mut c), Ok(None));
        assert_eq!(c.get_json("adminspace/enabled").unwrap(), "false");
        c.insert_json5("access_control/enabled", "true").unwrap();
        assert_eq!(enable_adminspace(&mut c), Ok(Some("peer".to_string())));
        c.insert_json5("mode", "\"router\"").unwrap();
        assert_eq!(enable_adminspace(&mut c), Ok(Some("router".to_string())));
        assert_eq!(c.get_json("adminspace/enabled").unwrap(), "true");
        assert_eq!(c.get_json("adminspace/permissions/read").unwrap(), "true");
        assert_eq!(c.get_json("adminspace/permissions/write").unwrap(), "false");
    }
}
