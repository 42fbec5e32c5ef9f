//! A property of the planner and the scheduler, on random DAGs: after a full run, editing one
//! stage's parameter reruns exactly that stage and its descendants, and undoing the edit reruns
//! nothing (every result is still in the cache). Each edit here raises the stage's output and
//! every stage passes a rise on (sums and unit-scale affine maps), so early cutoff stops
//! nothing and "exactly the descendants" is the expected set. Every stage has its own
//! parameters: two identical computations would share one cache entry and run once.

use std::collections::BTreeSet;
use std::path::Path;

use squeal_cache::Cache;
use squeal_engine::{
    Context, Decision, Instances, Override, Registry, RunOptions, RunRecord, Status, Study, plan,
};

/// xorshift64*: a fixed sequence of cases, the same on every machine.
struct Rng(u64);

impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 33) as usize % n
    }
}

/// A random study of `n` stages `s0..`: its text, each stage's parents, the parameter an edit
/// changes and the edited value.
struct RandomDag {
    text: String,
    parents: Vec<Vec<usize>>,
    edits: Vec<(&'static str, f64)>,
}

fn random_dag(rng: &mut Rng, n: usize) -> RandomDag {
    let mut text = String::from("stages:\n");
    let mut parents = Vec::with_capacity(n);
    let mut edits = Vec::with_capacity(n);
    for idx in 0..n {
        let roll = if idx == 0 { 0 } else { rng.below(10) };
        if roll < 2 {
            text.push_str(&format!(
                "  s{idx}:\n    kind: test.constant\n    params: {{ value: {idx} }}\n"
            ));
            parents.push(Vec::new());
            edits.push(("value", idx as f64 + 0.5));
        } else if roll < 6 {
            let parent = rng.below(idx);
            text.push_str(&format!(
                "  s{idx}:\n    kind: test.affine\n    inputs: {{ table: s{parent}.table }}\n    params: {{ offset: {idx} }}\n"
            ));
            parents.push(vec![parent]);
            edits.push(("offset", idx as f64 + 0.5));
        } else {
            let (a, b) = (rng.below(idx), rng.below(idx));
            text.push_str(&format!(
                "  s{idx}:\n    kind: test.sum\n    inputs: {{ a: s{a}.table, b: s{b}.table }}\n    params: {{ offset: {idx} }}\n"
            ));
            parents.push(vec![a, b]);
            edits.push(("offset", idx as f64 + 0.5));
        }
    }
    RandomDag {
        text,
        parents,
        edits,
    }
}

/// `stage` and every stage downstream of it.
fn descendants(parents: &[Vec<usize>], stage: usize) -> BTreeSet<String> {
    let mut reached = vec![false; parents.len()];
    reached[stage] = true;
    // Parents come before children, so one pass in order reaches everything.
    for idx in stage + 1..parents.len() {
        reached[idx] = parents[idx].iter().any(|parent| reached[*parent]);
    }
    (0..parents.len())
        .filter(|idx| reached[*idx])
        .map(|idx| format!("s{idx}"))
        .collect()
}

/// Plans and runs `text` with `overrides` in `dir`: the instances the plan says run, and those
/// that ran.
fn plan_and_run(
    dir: &Path,
    text: &str,
    overrides: &[Override],
) -> (BTreeSet<String>, BTreeSet<String>) {
    let registry = Registry::new(squeal_stages::test_kinds());
    let study = Study::from_text("random.yaml", "random", text, dir, &registry, overrides)
        .unwrap_or_else(|err| panic!("{err}\n{text}"));
    let instances = Instances::expand(&study, &study.targets);
    let cache = Cache::open(dir.join("cache")).unwrap();
    let record_path = dir.join("record.json");
    let record = RunRecord::load(&record_path);
    let context = Context {
        study: &study,
        instances: &instances,
        cache: &cache,
        record: &record,
    };
    let planned = plan(&context)
        .into_iter()
        .filter(|line| matches!(line.decision, Decision::Runs { .. }))
        .map(|line| line.instance)
        .collect();
    let options = RunOptions::local(Some(2), dir.join("out"), false);
    let report = squeal_engine::run(&context, &options, Some(&record_path)).unwrap();
    let ran = report
        .instances
        .iter()
        .filter(|instance| instance.status == Status::Ran)
        .map(|instance| instance.name.clone())
        .collect();
    (planned, ran)
}

#[test]
fn an_edit_reruns_exactly_the_descendants_of_what_it_touched_on_random_dags() {
    let mut rng = Rng(0x5eed_cafe_f00d_1234);
    for case in 0..60 {
        let n = 2 + rng.below(11);
        let dag = random_dag(&mut rng, n);
        let dir = tempfile::tempdir().unwrap();
        let everything: BTreeSet<String> = (0..n).map(|idx| format!("s{idx}")).collect();
        let (planned, ran) = plan_and_run(dir.path(), &dag.text, &[]);
        assert_eq!((&planned, &ran), (&everything, &everything), "case {case}");

        let edited = rng.below(n);
        let (param, value) = dag.edits[edited];
        let edit: Override = format!("s{edited}.{param}={value}").parse().unwrap();
        let expected = descendants(&dag.parents, edited);
        let (planned, ran) = plan_and_run(dir.path(), &dag.text, &[edit]);
        assert_eq!(
            ran, expected,
            "case {case}: editing s{edited}.{param} of\n{}",
            dag.text
        );
        assert_eq!(planned, expected, "case {case}: the plan of the edit");

        let (planned, ran) = plan_and_run(dir.path(), &dag.text, &[]);
        assert!(
            ran.is_empty(),
            "case {case}: undoing the edit reran {ran:?}"
        );
        assert!(
            planned.is_empty(),
            "case {case}: the undo's plan runs {planned:?}"
        );
    }
}
