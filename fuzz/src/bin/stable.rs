//! The stable-Rust fuzz runner: every target of `volga_fuzz` fuzzed without cargo-fuzz,
//! libFuzzer, nightly features or a C++ compiler (docs/FUZZING.md).
//!
//! ```text
//! stable [--seconds N] [--seed S] [--timeout SECS] [--memory-mb MB] [--threads T] [TARGET...]
//! stable --replay TARGET FILE...
//! ```
//!
//! Each target runs in a child process (this binary with `--child`) for N seconds (default
//! 60): its seeds (`fuzz/corpus/<target>/`) first, then mutations of them and of the
//! mutants the target accepted (`volga_fuzz::Mutator`: one to four bit flips, byte
//! insertions and deletions, chunk copies, splices, boundary numbers, truncations), each
//! under `catch_unwind`. A panic is a crash: the first input for each distinct panic site
//! (`file:line:column`) is saved as `fuzz/artifacts/<target>/crash-…` with its message and
//! backtrace beside it (`.txt`), and fuzzing goes on. An input running longer than the
//! timeout (default 10 s) or an abort (an allocation over the memory cap, default 2 GiB
//! live or in one request, fails as out-of-memory does) ends the child: the parent saves
//! the input being run (`timeout-…`, `abort-…`) and starts a new child for the time left.
//! The summary gives per target the seconds, executions, inputs accepted and distinct
//! crash sites; the exit status is 1 when anything crashed, 2 on a usage error.
//!
//! `--replay` runs files once in this process with the default panic hook (set
//! `RUST_BACKTRACE=1` for the stack), to reproduce a crash.

use std::alloc::{GlobalAlloc, Layout, System};
use std::collections::{BTreeMap, HashSet};
use std::io::{BufRead, BufReader, Seek, Write};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use volga_fuzz::{Mutator, TARGETS};

/// The system allocator with a cap: a request that would take the live bytes over
/// [`CAP`] (or is larger than it) fails, which aborts the process the way running out of
/// memory does ("memory allocation of N bytes failed").
struct Capped;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static CAP: AtomicUsize = AtomicUsize::new(usize::MAX);

unsafe impl GlobalAlloc for Capped {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !reserve(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded unchanged to the system allocator.
        let p = unsafe { System.alloc(layout) };
        if p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !reserve(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded unchanged to the system allocator.
        let p = unsafe { System.alloc_zeroed(layout) };
        if p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was allocated by `System` with `layout`.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let old = layout.size();
        if new_size > old && !reserve(new_size - old) {
            return std::ptr::null_mut();
        }
        // SAFETY: `ptr` was allocated by `System` with `layout`; the caller upholds the rest.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        match (p.is_null(), new_size > old) {
            (true, true) => {
                LIVE.fetch_sub(new_size - old, Ordering::Relaxed);
            }
            (false, false) => {
                LIVE.fetch_sub(old - new_size, Ordering::Relaxed);
            }
            _ => {}
        }
        p
    }
}

/// Counts `bytes` as live unless that would pass the cap.
fn reserve(bytes: usize) -> bool {
    let cap = CAP.load(Ordering::Relaxed);
    let before = LIVE.fetch_add(bytes, Ordering::Relaxed);
    if bytes > cap || before.saturating_add(bytes) > cap {
        LIVE.fetch_sub(bytes, Ordering::Relaxed);
        return false;
    }
    true
}

#[global_allocator]
static ALLOCATOR: Capped = Capped;

/// Exit status of a child whose input ran past the timeout.
const TIMEOUT_EXIT: i32 = 77;

/// Largest input the mutator makes (bytes).
const MAX_LEN: usize = 64 * 1024;

/// Mutants kept for further mutation (inputs the target accepted).
const POOL: usize = 4096;

struct Options {
    seconds: f64,
    seed: u64,
    timeout: f64,
    memory_mb: u64,
    threads: usize,
    targets: Vec<String>,
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("--child") => child(&args[1..]),
        Some("--replay") => replay(&args[1..]),
        Some("-h" | "--help") => {
            println!("{}", usage());
            ExitCode::SUCCESS
        }
        _ => match parse(&args) {
            Ok(options) => parent(&options),
            Err(message) => {
                eprintln!("{message}\n{}", usage());
                ExitCode::from(2)
            }
        },
    }
}

fn usage() -> String {
    format!(
        "usage: stable [--seconds N] [--seed S] [--timeout SECS] [--memory-mb MB] [--threads T] [TARGET...]\n       \
         stable --replay TARGET FILE...\ntargets: {}",
        TARGETS.join(" ")
    )
}

fn parse(args: &[String]) -> Result<Options, String> {
    let mut o = Options {
        seconds: 60.0,
        seed: 1,
        timeout: 10.0,
        memory_mb: 2048,
        threads: 1,
        targets: Vec::new(),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value")).cloned();
        let bad = |name: &str, v: &str| format!("{name}: `{v}` is not a valid value");
        match a.as_str() {
            "--seconds" => {
                let v = value(a)?;
                o.seconds = v.parse().ok().filter(|s: &f64| *s > 0.0).ok_or(bad(a, &v))?;
            }
            "--seed" => {
                let v = value(a)?;
                o.seed = v.parse().map_err(|_| bad(a, &v))?;
            }
            "--timeout" => {
                let v = value(a)?;
                o.timeout = v.parse().ok().filter(|s: &f64| *s > 0.0).ok_or(bad(a, &v))?;
            }
            "--memory-mb" => {
                let v = value(a)?;
                o.memory_mb = v.parse().ok().filter(|&m| m > 0).ok_or(bad(a, &v))?;
            }
            "--threads" => {
                let v = value(a)?;
                o.threads = v.parse().ok().filter(|&t| t > 0).ok_or(bad(a, &v))?;
            }
            t if TARGETS.contains(&t) => o.targets.push(t.to_string()),
            other => return Err(format!("unknown argument or target `{other}`")),
        }
    }
    if o.targets.is_empty() {
        o.targets = TARGETS.iter().map(|t| t.to_string()).collect();
    }
    Ok(o)
}

fn fuzz_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn work_dir() -> PathBuf {
    fuzz_dir().join("target/stable")
}

fn artifact_dir(target: &str) -> PathBuf {
    fuzz_dir().join("artifacts").join(target)
}

/// What one target's run came to.
#[derive(Default)]
struct Tally {
    seconds: f64,
    execs: u64,
    accepted: u64,
    children: u32,
    /// Crash site → (kind, saved input, message).
    sites: BTreeMap<String, (String, PathBuf, String)>,
    crashing_execs: u64,
}

fn parent(o: &Options) -> ExitCode {
    let exe = std::env::current_exe().expect("the runner's own path");
    std::fs::create_dir_all(work_dir()).expect("create fuzz/target/stable");
    let mut tallies = Vec::new();
    for target in &o.targets {
        std::fs::create_dir_all(artifact_dir(target)).expect("create the artifact folder");
        let start = Instant::now();
        let deadline = start + Duration::from_secs_f64(o.seconds);
        let mut tally = Tally::default();
        let mut seed = o.seed;
        while deadline.saturating_duration_since(Instant::now()) > Duration::from_millis(200) {
            let left = deadline.saturating_duration_since(Instant::now()).as_secs_f64();
            run_child(&exe, o, target, left, seed, &mut tally);
            seed = seed.wrapping_add(0x1_0000);
        }
        tally.seconds = start.elapsed().as_secs_f64();
        let line = summary_line(target, &tally);
        println!("{line}");
        for (site, (kind, file, message)) in &tally.sites {
            println!("    {kind} at {site}: {message}\n        input: {}", file.display());
        }
        tallies.push((target.clone(), tally));
    }
    println!(
        "\n== stable fuzz summary ({} s per target, seed {}, {} thread(s), timeout {} s, memory cap {} MiB)",
        o.seconds, o.seed, o.threads, o.timeout, o.memory_mb
    );
    let mut crashed = false;
    for (target, tally) in &tallies {
        println!("{}", summary_line(target, tally));
        crashed |= !tally.sites.is_empty();
    }
    if crashed {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

fn summary_line(target: &str, t: &Tally) -> String {
    format!(
        "{target:<12} {:>6.0}s {:>10} execs {:>9.0}/s {:>9} accepted  crashes: {} site(s), {} input(s){}",
        t.seconds,
        t.execs,
        t.execs as f64 / t.seconds.max(1e-9),
        t.accepted,
        t.sites.len(),
        t.crashing_execs,
        if t.children > 1 {
            format!(" ({} children)", t.children)
        } else {
            String::new()
        }
    )
}

/// Runs one child for `seconds` and adds what it reports to `tally`.
fn run_child(exe: &Path, o: &Options, target: &str, seconds: f64, seed: u64, tally: &mut Tally) {
    let log_path = work_dir().join(format!("{target}.stderr"));
    let log = std::fs::File::create(&log_path).expect("create the child's log");
    let mut child = Command::new(exe)
        .args([
            "--child",
            target,
            &format!("{seconds}"),
            &seed.to_string(),
            &o.timeout.to_string(),
            &o.memory_mb.to_string(),
        ])
        .env("RAYON_NUM_THREADS", o.threads.to_string())
        .env("RUST_BACKTRACE", "0")
        .stdout(Stdio::piped())
        .stderr(Stdio::from(log))
        .spawn()
        .expect("start a child");
    tally.children += 1;
    let (mut execs, mut accepted) = (0, 0);
    let mut timed_out = false;
    for line in BufReader::new(child.stdout.take().expect("child stdout")).lines() {
        let Ok(line) = line else { break };
        let mut fields = line.splitn(2, ' ');
        match (fields.next(), fields.next()) {
            (Some("progress"), Some(rest)) => {
                let mut n = rest.split(' ').map(|x| x.parse::<u64>().unwrap_or(0));
                execs = n.next().unwrap_or(0);
                accepted = n.next().unwrap_or(0);
                tally.crashing_execs += n.next().unwrap_or(0);
            }
            (Some("crash"), Some(rest)) => {
                let parts: Vec<&str> = rest.splitn(3, '\t').collect();
                if let [site, file, message] = parts[..] {
                    tally.sites.entry(site.to_string()).or_insert((
                        "panic".to_string(),
                        PathBuf::from(file),
                        message.to_string(),
                    ));
                }
            }
            (Some("timeout"), _) => timed_out = true,
            _ => {}
        }
    }
    let status = child.wait().expect("wait for the child");
    tally.execs += execs;
    tally.accepted += accepted;
    if status.success() {
        return;
    }
    // The child died on an input: the one it was running is in `<target>.current`.
    tally.execs += 1;
    tally.crashing_execs += 1;
    let kind = if timed_out || status.code() == Some(TIMEOUT_EXIT) {
        "timeout"
    } else {
        "abort"
    };
    let stderr = std::fs::read_to_string(&log_path).unwrap_or_default();
    let noise = ["note:", "stack backtrace", "skipping backtrace"];
    let message = stderr
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty() && !noise.iter().any(|n| l.starts_with(n)))
        .unwrap_or("(no message)")
        .to_string();
    let message = format!("{message} [{status}]");
    let input = std::fs::read(work_dir().join(format!("{target}.current"))).unwrap_or_default();
    // One site per kind and message shape (digits dropped: sizes vary between inputs).
    let shape: String = message.chars().filter(|c| !c.is_ascii_digit()).collect();
    let site = format!("{kind}: {shape}");
    if tally.sites.contains_key(&site) {
        return;
    }
    let file = artifact_dir(target).join(format!("{kind}-{:016x}", fnv(&input)));
    std::fs::write(&file, &input).expect("save the crashing input");
    std::fs::write(file.with_extension("txt"), &stderr).expect("save the child's stderr");
    tally.sites.insert(site, (kind.to_string(), file, message));
}

fn fnv(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    })
}

/// The panic being unwound: site, message, and a backtrace when the site is new.
struct Panic {
    site: String,
    message: String,
    backtrace: Option<String>,
}

static PANIC: Mutex<Option<Panic>> = Mutex::new(None);
/// Sites whose backtrace has been taken (once each: taking one is slow).
static TRACED: Mutex<Option<HashSet<String>>> = Mutex::new(None);

fn install_hook() {
    std::panic::set_hook(Box::new(|info| {
        let site = info.location().map_or("unknown".to_string(), |l| {
            format!("{}:{}:{}", short_path(l.file()), l.line(), l.column())
        });
        let message = if let Some(s) = info.payload().downcast_ref::<&str>() {
            s.to_string()
        } else if let Some(s) = info.payload().downcast_ref::<String>() {
            s.clone()
        } else {
            "(no message)".to_string()
        };
        let new = TRACED
            .lock()
            .map(|mut traced| traced.get_or_insert_with(HashSet::new).insert(site.clone()))
            .unwrap_or(false);
        let backtrace = new.then(|| std::backtrace::Backtrace::force_capture().to_string());
        if let Ok(mut slot) = PANIC.lock() {
            // The last panic of an input is the one that escaped (a library may catch an
            // earlier one and panic again, as the harness does for the glTF parser).
            *slot = Some(Panic {
                site,
                message,
                backtrace,
            });
        }
    }));
}

/// A source path from its crate's folder on (`volga-sculpt/src/edit.rs`,
/// `tobj-4.0.5/src/lib.rs`): the last three components.
fn short_path(file: &str) -> String {
    let parts: Vec<&str> = file.split('/').collect();
    parts[parts.len().saturating_sub(3)..].join("/")
}

fn corpus(target: &str) -> Vec<Vec<u8>> {
    let dir = fuzz_dir().join("corpus").join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a corpus entry").path())
        .collect();
    files.sort();
    files.iter().map(|f| std::fs::read(f).expect("read a seed")).collect()
}

/// `--child TARGET SECONDS SEED TIMEOUT MEMORY_MB`: the fuzzing loop, reporting on stdout.
fn child(args: &[String]) -> ExitCode {
    let [target, seconds, seed, timeout, memory_mb] = args else {
        eprintln!("--child TARGET SECONDS SEED TIMEOUT MEMORY_MB");
        return ExitCode::from(2);
    };
    let parse = |s: &String| s.parse::<f64>().expect("a number");
    let deadline = Instant::now() + Duration::from_secs_f64(parse(seconds));
    let timeout = Duration::from_secs_f64(parse(timeout));
    let mut mutator = Mutator::new(seed.parse().expect("a seed"));
    let seeds = corpus(target);
    let harness = volga_fuzz::harness();
    let current_path = work_dir().join(format!("{target}.current"));
    let mut current = std::fs::File::create(&current_path).expect("create the current-input file");
    install_hook();
    let mut reported = HashSet::new();
    CAP.store((parse(memory_mb) as usize).saturating_mul(1 << 20), Ordering::Relaxed);

    // The watchdog: an input running past the timeout ends the process.
    static STARTED_MS: AtomicU64 = AtomicU64::new(0);
    let epoch = Instant::now();
    std::thread::spawn(move || loop {
        std::thread::sleep(Duration::from_millis(50));
        let started = STARTED_MS.load(Ordering::Relaxed);
        if started > 0 && epoch.elapsed().as_millis() as u64 > started + timeout.as_millis() as u64 {
            println!("timeout");
            let _ = std::io::stdout().flush();
            eprintln!("an input ran longer than {} s", timeout.as_secs_f64());
            std::process::exit(TIMEOUT_EXIT);
        }
    });

    let mut pool: Vec<Vec<u8>> = Vec::new();
    let (mut execs, mut accepted, mut crashing) = (0u64, 0u64, 0u64);
    let mut last_report = Instant::now();
    let mut out = std::io::stdout();
    let mut index = 0usize;
    while Instant::now() < deadline {
        let data = if index < seeds.len() {
            index += 1;
            seeds[index - 1].clone()
        } else {
            let n = seeds.len() + pool.len();
            let pick = |k: usize| {
                if k < seeds.len() {
                    &seeds[k]
                } else {
                    &pool[k - seeds.len()]
                }
            };
            let base = pick(mutator.next_u64() as usize % n);
            let other = pick(mutator.next_u64() as usize % n);
            let mut data = mutator.mutate(base, other);
            data.truncate(MAX_LEN);
            data
        };
        // Saved before running, so the parent finds it if the process dies.
        current.set_len(0).expect("truncate the current-input file");
        current.rewind().expect("rewind the current-input file");
        current.write_all(&data).expect("write the current-input file");
        *PANIC.lock().unwrap() = None;
        STARTED_MS.store(epoch.elapsed().as_millis() as u64 + 1, Ordering::Relaxed);
        let result = catch_unwind(AssertUnwindSafe(|| harness.run(target, &data)));
        STARTED_MS.store(0, Ordering::Relaxed);
        execs += 1;
        match result {
            Ok(true) => {
                accepted += 1;
                if index >= seeds.len() {
                    if pool.len() < POOL {
                        pool.push(data);
                    } else {
                        let k = mutator.next_u64() as usize % POOL;
                        pool[k] = data;
                    }
                }
            }
            Ok(false) => {}
            Err(_) => {
                crashing += 1;
                let panic = PANIC.lock().unwrap().take();
                let Some(panic) = panic else { continue };
                if reported.insert(panic.site.clone()) {
                    let name: String = panic
                        .site
                        .chars()
                        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                        .collect();
                    let file = artifact_dir(target).join(format!("crash-{name}-{:016x}", fnv(&data)));
                    std::fs::write(&file, &data).expect("save the crashing input");
                    let report = format!(
                        "target: {target}\nsite: {}\nmessage: {}\n\n{}",
                        panic.site,
                        panic.message,
                        panic
                            .backtrace
                            .unwrap_or_else(|| "(backtrace taken at an earlier, caught panic of this site)".into())
                    );
                    std::fs::write(file.with_extension("txt"), report).expect("save the crash report");
                    let message = panic.message.lines().next().unwrap_or("").replace('\t', " ");
                    let _ = writeln!(out, "crash {}\t{}\t{message}", panic.site, file.display());
                }
            }
        }
        if last_report.elapsed() > Duration::from_millis(250) {
            let _ = writeln!(out, "progress {execs} {accepted} {crashing}");
            crashing = 0;
            last_report = Instant::now();
        }
    }
    let _ = writeln!(out, "progress {execs} {accepted} {crashing}");
    ExitCode::SUCCESS
}

/// `--replay TARGET FILE...`: each file once, panics reported by the default hook.
fn replay(args: &[String]) -> ExitCode {
    let Some((target, files)) = args.split_first() else {
        eprintln!("{}", usage());
        return ExitCode::from(2);
    };
    if !TARGETS.contains(&target.as_str()) {
        eprintln!("unknown target `{target}`\n{}", usage());
        return ExitCode::from(2);
    }
    let harness = volga_fuzz::harness();
    for file in files {
        let data = std::fs::read(file).unwrap_or_else(|e| panic!("{file}: {e}"));
        let start = Instant::now();
        let accepted = harness.run(target, &data);
        println!(
            "{file}: {} in {:.3} s",
            if accepted { "accepted" } else { "refused" },
            start.elapsed().as_secs_f64()
        );
    }
    ExitCode::SUCCESS
}
