//! Results other people can read: every file a run writes takes the mode the umask gives, and
//! a cache shared by a group serves its members, each adding entries the others read, while
//! refusing whoever is outside the group.

mod common;

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::Workspace;

const STUDY: &str = "\
study: shared
stages:
  source:
    kind: test.constant
    params: { value: 2.0, rows: 4 }
  scaled:
    kind: test.affine
    inputs: { table: source.table }
    params: { scale: 1.5 }
";

/// The mode bits (rwx for owner, group, others, and setgid) of every file under `dir`.
fn modes(dir: &Path) -> Vec<(PathBuf, u32)> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        let metadata = std::fs::symlink_metadata(&path).unwrap();
        if metadata.is_dir() {
            found.extend(modes(&path));
        } else {
            found.push((path, metadata.mode() & 0o7777));
        }
    }
    found.sort();
    found
}

/// `squeal ARGS` under `umask`, in `dir`, as a shell would start it.
fn squeal_with_umask(dir: &Path, umask: &str, args: &str) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!(
            "umask {umask} && exec {} {args}",
            env!("CARGO_BIN_EXE_squeal")
        ))
        .current_dir(dir)
        .env("SQUEAL_TEST_KINDS", "1")
        .env_remove("SQUEAL_CACHE")
        .output()
        .expect("run squeal")
}

#[test]
fn every_file_a_run_writes_takes_the_mode_the_umask_gives() {
    for (umask, file, entry) in [("022", 0o644, 0o444), ("077", 0o600, 0o400)] {
        let workspace = Workspace::new();
        workspace.write("shared.yaml", STUDY);
        for args in ["run shared.yaml --out out", "report shared.yaml --out out"] {
            let output = squeal_with_umask(workspace.path(), umask, args);
            assert!(
                output.status.success(),
                "{args}: {}",
                String::from_utf8_lossy(&output.stderr)
            );
        }
        let written = modes(workspace.path());
        let named = |suffix: &str| {
            written
                .iter()
                .find(|(path, _)| path.to_string_lossy().ends_with(suffix))
                .unwrap_or_else(|| panic!("no {suffix} in {written:?}"))
                .1
        };
        for suffix in [
            "out/scaled/table.parquet",
            "out/manifest.parquet",
            "out/report.html",
            ".squeal/record/shared.json",
        ] {
            assert_eq!(named(suffix), file, "umask {umask}: {suffix}");
        }
        let entries: Vec<&(PathBuf, u32)> = written
            .iter()
            .filter(|(path, _)| {
                let path = path.to_string_lossy();
                path.contains("/cache/objects/") || path.contains("/cache/actions/")
            })
            .collect();
        assert!(!entries.is_empty());
        for (path, mode) in entries {
            assert_eq!(*mode, entry, "umask {umask}: {}", path.display());
        }
    }
}

/// Runs `command` (a shell line) as `user` under umask 022, with the test kinds.
fn as_user(user: &str, command: &str) -> Output {
    Command::new("runuser")
        .args(["-u", user, "--", "sh", "-c"])
        .arg(format!("umask 022 && {command}"))
        .env("SQUEAL_TEST_KINDS", "1")
        .env_remove("SQUEAL_CACHE")
        .output()
        .expect("runuser")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// The instances a run computed, from its summary line (`… N ran, …`), which it prints.
fn ran(output: &Output) -> usize {
    let text = stderr(output);
    eprintln!("{}", text.lines().last().unwrap_or_default());
    let line = text
        .lines()
        .find(|line| line.contains(" ran, "))
        .unwrap_or_else(|| panic!("no summary in:\n{text}"));
    let before = &line[..line.find(" ran, ").unwrap()];
    before
        .rsplit(' ')
        .next()
        .and_then(|count| count.parse().ok())
        .unwrap_or_else(|| panic!("no count in `{line}`"))
}

fn system(program: &str, args: &[&str]) {
    let status = Command::new(program).args(args).status().expect(program);
    assert!(status.success(), "{program} {args:?}");
}

#[test]
#[ignore = "creates Unix users and a group: needs root (.ci/run runs it)"]
fn shared_cache_two_users() {
    // SAFETY: geteuid cannot fail.
    assert_eq!(
        unsafe { libc::geteuid() },
        0,
        "run as root: it creates users"
    );
    let (group, alice, bob, carol) = ("squeal_team", "squeal_alice", "squeal_bob", "squeal_carol");
    let _ = Command::new("groupadd").args(["-f", group]).status();
    for (user, primary) in [(alice, group), (bob, group), (carol, "nogroup")] {
        let _ = Command::new("useradd")
            .args(["-M", "-N", "-g", primary, "-s", "/bin/sh", user])
            .status();
    }
    // A folder every user can enter, the binary and the study in it.
    let workspace = Workspace::new();
    let root = workspace.path();
    std::fs::set_permissions(root, std::fs::Permissions::from_mode(0o755)).unwrap();
    let squeal = root.join("squeal");
    std::fs::copy(env!("CARGO_BIN_EXE_squeal"), &squeal).unwrap();
    std::fs::set_permissions(&squeal, std::fs::Permissions::from_mode(0o755)).unwrap();
    workspace.write("shared.yaml", STUDY);
    for user in [alice, bob, carol] {
        let home = root.join(user);
        std::fs::create_dir(&home).unwrap();
        system("chown", &[user, &home.display().to_string()]);
    }
    // The cache: a folder of the team's group, made shared by its owner.
    let cache = root.join("cache");
    system(
        "install",
        &["-d", "-o", alice, "-g", group, &cache.display().to_string()],
    );
    let run = |user: &str, extra: &str| {
        as_user(
            user,
            &format!(
                "cd {root} && SQUEAL_STATE_DIR={root}/{user}/state {squeal} --cache {cache} run shared.yaml --out {root}/{user}/out {extra}",
                root = root.display(),
                squeal = squeal.display(),
                cache = cache.display()
            ),
        )
    };
    let init = as_user(
        alice,
        &format!(
            "{} cache init --shared group {}",
            squeal.display(),
            cache.display()
        ),
    );
    assert!(init.status.success(), "{}", stderr(&init));
    let folder_mode = std::fs::metadata(cache.join("objects/ab")).unwrap().mode() & 0o7777;
    assert_eq!(folder_mode, 0o2770);

    // Alice runs the study: both instances computed.
    let first = run(alice, "");
    assert!(first.status.success(), "{}", stderr(&first));
    assert_eq!(ran(&first), 2);
    // Bob reruns it from her entries: nothing computed.
    let second = run(bob, "");
    assert!(second.status.success(), "{}", stderr(&second));
    assert_eq!(ran(&second), 0, "{}", stderr(&second));
    // Bob edits a parameter: his entries are the group's, read-only, and Alice reads them.
    let edited = run(bob, "--set scaled.scale=2");
    assert!(edited.status.success(), "{}", stderr(&edited));
    assert_eq!(ran(&edited), 1);
    for (path, mode) in modes(&cache.join("objects")) {
        let metadata = std::fs::metadata(&path).unwrap();
        assert_eq!(mode, 0o440, "{}", path.display());
        assert_eq!(
            metadata.gid(),
            std::fs::metadata(&cache).unwrap().gid(),
            "{}: the setgid folder keeps the group",
            path.display()
        );
    }
    let again = run(alice, "--set scaled.scale=2");
    assert!(again.status.success(), "{}", stderr(&again));
    assert_eq!(ran(&again), 0, "{}", stderr(&again));
    // Each reads the other's outputs.
    for (reader, writer) in [(alice, bob), (bob, alice)] {
        let read = as_user(
            reader,
            &format!(
                "cat {}/{writer}/out/scaled/table.parquet > /dev/null",
                root.display()
            ),
        );
        assert!(
            read.status.success(),
            "{reader} reading {writer}'s output: {}",
            stderr(&read)
        );
    }
    // Both at once on the same new entries: each run succeeds, the cache stays whole.
    let both: Vec<std::thread::JoinHandle<Output>> = [alice, bob]
        .map(|user| {
            let line = format!(
                "cd {root} && SQUEAL_STATE_DIR={root}/{user}/state {squeal} --cache {cache} run shared.yaml --out {root}/{user}/race --set scaled.scale=3",
                root = root.display(),
                squeal = squeal.display(),
                cache = cache.display()
            );
            let user = user.to_string();
            std::thread::spawn(move || as_user(&user, &line))
        })
        .into_iter()
        .collect();
    for output in both {
        let output = output.join().unwrap();
        assert!(output.status.success(), "{}", stderr(&output));
    }
    let verify = as_user(
        bob,
        &format!(
            "{} --cache {} cache verify",
            squeal.display(),
            cache.display()
        ),
    );
    assert!(verify.status.success(), "{}", stderr(&verify));
    eprintln!("{}", String::from_utf8_lossy(&verify.stdout).trim());

    // Carol, outside the group, is refused in one line and changes nothing.
    let before = modes(&cache);
    let refused = run(carol, "");
    assert!(!refused.status.success());
    let message = stderr(&refused);
    eprintln!("{carol}: {message}");
    assert!(
        message.contains("is shared by the members of group `squeal_team`")
            && message.contains("not one"),
        "{message}"
    );
    assert_eq!(modes(&cache), before);
    // With a cache of her own, in a study folder she may not write: the error names the run
    // record and what to do.
    let record = as_user(
        carol,
        &format!(
            "cd {root} && {squeal} --cache {root}/{carol}/cache run shared.yaml --out {root}/{carol}/out",
            root = root.display(),
            squeal = squeal.display()
        ),
    );
    assert!(!record.status.success());
    let message = stderr(&record);
    eprintln!("{carol}: {}", message.lines().last().unwrap_or_default());
    assert!(
        message.contains("writing the run record") && message.contains("SQUEAL_STATE_DIR"),
        "{message}"
    );

    // A shard Alice closes to the group: Bob's gc removes the rest and names what it could not.
    let closed = cache.join("objects").join("ab");
    let kept = closed.join(format!("ab{}", "0".repeat(62)));
    let close = as_user(
        alice,
        &format!(
            "echo x > {0} && chmod 2750 {1}",
            kept.display(),
            closed.display()
        ),
    );
    assert!(close.status.success(), "{}", stderr(&close));
    let gc = as_user(
        bob,
        &format!(
            "{} --cache {} cache gc --max-size 0",
            squeal.display(),
            cache.display()
        ),
    );
    assert!(gc.status.success(), "{}", stderr(&gc));
    let said = String::from_utf8_lossy(&gc.stdout).into_owned();
    eprintln!("bob's gc:\n{said}");
    assert!(
        said.contains("1 entries could not be removed")
            && said.contains(&kept.display().to_string()),
        "{said}"
    );
    let left: Vec<PathBuf> = modes(&cache.join("objects"))
        .into_iter()
        .map(|(path, _)| path)
        .collect();
    assert_eq!(left, [kept]);
    assert!(modes(&cache.join("actions")).is_empty());
}
