//! Hostile scenario files: random corruptions of a valid file must give an error naming a
//! field or a line (or a valid scenario) and never a panic.

use host_sim::scenario;
use proptest::prelude::*;

const JUNK: [&str; 12] = ["-1", "0", "nan", "inf", "-inf", "1e308", "\"x\"", "[", "[1, 2]", "true", "{}", "= ="];

fn corrupt(text: &str, line: usize, junk: &str, mode: u8) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let k = line % lines.len();
    let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    match mode % 3 {
        0 => {
            // Replace the value of the line (if it has one).
            if let Some((key, _)) = lines[k].split_once('=') {
                out[k] = format!("{key}= {junk}");
            } else {
                out[k] = junk.to_string();
            }
        }
        1 => {
            out.remove(k);
        }
        _ => out.insert(k, junk.to_string()),
    }
    out.join("\n")
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    #[test]
    fn corrupted_scenarios_never_panic_and_errors_say_where(line in 0usize..200, j in 0usize..JUNK.len(), mode in 0u8..3) {
        let text = corrupt(scenario::PAPER_10UAV, line, JUNK[j], mode);
        match scenario::parse(&text, "fuzz.toml") {
            Ok(_) => {}
            Err(e) => {
                prop_assert!(e.line.is_some() || e.field.is_some(), "error locates nothing: {e}");
                prop_assert!(!e.message.is_empty());
            }
        }
    }

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes);
        prop_assert!(scenario::parse(&text, "bytes.toml").is_err());
    }
}
