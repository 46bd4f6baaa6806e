//! Every input ends cleanly: seeded mutants of the example scenarios (numbers swapped for
//! extreme ones, values of the wrong type, fields dropped) each end within a time limit with
//! exit 0 or a located exit 2 (`FILE:LINE:COL: ...`), never a panic or a hang.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};

/// Mutants tried, and the seed that draws them (a failure names the case to reproduce).
const CASES: usize = 240;
const SEED: u64 = 0x6d75_7461_6e74;

/// How long one command may take: a debug build validates in milliseconds and runs a short
/// horizon in well under a second, so this only trips on a hang.
const LIMIT: Duration = Duration::from_secs(20);

/// Values a mutant puts in place of a number: the extremes the engine must refuse or survive.
const EXTREMES: &[&str] = &[
    "0",
    "-1",
    "0.0",
    "-0.5",
    "1e-320",
    "-1e308",
    "1e308",
    "1e9",
    "4294967296",
    "18446744073709551616",
    "NaN",
    "inf",
    "-inf",
    "\"two\"",
    "()",
    "[]",
    "1000000",
    "1e-6",
];

fn examples() -> Vec<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut v: Vec<PathBuf> = ["examples/scenarios", "examples/behaviours"]
        .iter()
        .flat_map(|d| std::fs::read_dir(root.join(d)).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    v.sort();
    v
}

/// Byte ranges of the numbers in `text` outside comments and strings.
fn numbers(text: &str) -> Vec<std::ops::Range<usize>> {
    let b = text.as_bytes();
    let (mut i, mut out) = (0, Vec::new());
    while i < b.len() {
        match b[i] {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            b'"' => {
                i += 1;
                while i < b.len() && b[i] != b'"' {
                    i += 1;
                }
                i += 1;
            }
            c if c.is_ascii_digit()
                || (c == b'-' && b.get(i + 1).is_some_and(u8::is_ascii_digit)) =>
            {
                let start = i;
                i += 1;
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'.' || b[i] == b'_')
                {
                    i += 1;
                }
                out.push(start..i);
            }
            c if c.is_ascii_alphabetic() || c == b'_' => {
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                    i += 1;
                }
            }
            _ => i += 1,
        }
    }
    out
}

/// One mutation of `text`: a number replaced by an extreme or scaled, or a `name: value`
/// field dropped.
fn mutate(text: &str, rng: &mut impl Rng) -> String {
    let nums = numbers(text);
    if rng.gen_bool(0.8) && !nums.is_empty() {
        let r = nums[rng.gen_range(0..nums.len())].clone();
        let old = &text[r.clone()];
        let new = match rng.gen_range(0..4) {
            0 => format!("{old}0000"),
            1 => format!("-{old}"),
            _ => EXTREMES[rng.gen_range(0..EXTREMES.len())].to_string(),
        };
        return format!("{}{new}{}", &text[..r.start], &text[r.end..]);
    }
    // Drop a field: from a name followed by `:` to the next comma at the same depth.
    let fields: Vec<usize> = text
        .match_indices(": ")
        .map(|(i, _)| i)
        .filter(|&i| !text[..i].rsplit('\n').next().unwrap_or("").contains("//"))
        .collect();
    if fields.is_empty() {
        return text.to_string();
    }
    let colon = fields[rng.gen_range(0..fields.len())];
    let start = text[..colon]
        .rfind(|c: char| !(c.is_alphanumeric() || c == '_'))
        .map_or(0, |k| k + 1);
    let mut depth = 0i32;
    let mut end = colon;
    for (k, c) in text[colon..].char_indices() {
        match c {
            '(' | '[' | '{' => depth += 1,
            ')' | ']' | '}' => {
                depth -= 1;
                if depth < 0 {
                    end = colon + k;
                    break;
                }
            }
            ',' if depth == 0 => {
                end = colon + k + 1;
                break;
            }
            _ => {}
        }
    }
    format!("{}{}", &text[..start], &text[end..])
}

/// Runs `nekosim args`, killed if it takes longer than [`LIMIT`]: its exit code and stderr,
/// or `None` on a hang.
fn run(args: &[&str]) -> Option<(Option<i32>, String)> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("nekosim starts");
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
            return Some((status.code(), err));
        }
        if start.elapsed() > LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Whether `err` is one located line about `file`: `FILE:LINE:COL: message`.
fn located(err: &str, file: &Path) -> bool {
    let Some(rest) = err.strip_prefix(&format!("{}:", file.display())) else {
        return false;
    };
    let mut parts = rest.splitn(3, ':');
    let num =
        |s: Option<&str>| s.is_some_and(|s| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()));
    err.lines().count() == 1
        && num(parts.next())
        && num(parts.next())
        && parts
            .next()
            .is_some_and(|m| m.starts_with(' ') && m.len() > 1)
}

#[test]
fn mutants_of_the_examples_end_with_exit_0_or_a_located_exit_2() {
    let examples = examples();
    assert!(examples.len() >= 10);
    let texts: Vec<String> = examples
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SEED);
    let (mut valid, mut refused) = (0, 0);
    for case in 0..CASES {
        let k = rng.gen_range(0..examples.len());
        let mut text = mutate(&texts[k], &mut rng);
        if rng.gen_bool(0.3) {
            text = mutate(&text, &mut rng);
        }
        let name = examples[k].file_stem().unwrap().to_string_lossy();
        let file = dir.path().join(format!("{case}-{name}.ron"));
        std::fs::write(&file, &text).unwrap();
        let path = file.to_str().unwrap();
        let what = format!("case {case} (seed {SEED:#x}), a mutant of {name}:\n{text}");
        let (code, err) =
            run(&["validate", path]).unwrap_or_else(|| panic!("validate hangs: {what}"));
        assert!(!err.contains("panicked"), "{what}\n{err}");
        match code {
            Some(0) => {}
            Some(2) => {
                assert!(located(&err, &file), "an unlocated error: {err}\n{what}");
                refused += 1;
                continue;
            }
            other => panic!("validate exits {other:?}: {err}\n{what}"),
        }
        valid += 1;
        // Valid mutants run a short horizon: they must end, and the run may not refuse what
        // validation accepted.
        let (code, err) = run(&["run", path, "--until", "0.5", "--quiet"])
            .unwrap_or_else(|| panic!("run hangs: {what}"));
        assert_eq!(code, Some(0), "run: {err}\n{what}");
    }
    eprintln!("{CASES} mutants: {valid} valid and run, {refused} refused at their place");
    // The mutants exercise both sides.
    assert!(
        valid >= CASES / 10 && refused >= CASES / 4,
        "{valid} valid, {refused} refused"
    );
}
