//! `squeal stages`: every stage kind with its parameters, inputs and outputs.

use std::process::ExitCode;

use squeal_engine::Registry;

pub fn stages(registry: &Registry) -> ExitCode {
    let compute_time = squeal_engine::compute_time_port();
    println!(
        "Every stage also has the output `{}` (table): {}.\n",
        compute_time.name, compute_time.doc
    );
    for stage in registry.iter() {
        let resources = stage.resources();
        let placement = match resources.placement {
            squeal_stages::Placement::Driver => String::new(),
            squeal_stages::Placement::Job => format!(
                "; a Slurm job of {} CPUs, {} MB",
                resources.threads, resources.memory_mb
            ),
        };
        println!(
            "{} (v{}{placement}): {}",
            stage.kind(),
            stage.version(),
            stage.doc()
        );
        for port in stage.inputs() {
            let many = match port.arity {
                squeal_stages::Arity::One => "",
                squeal_stages::Arity::Many => ", gathers a sweep",
                squeal_stages::Arity::List => ", a list of references",
            };
            let optional = if port.optional { ", optional" } else { "" };
            println!(
                "  input  {:<20} {}{many}{optional}: {}",
                port.name, port.ty, port.doc
            );
        }
        for port in stage.outputs() {
            println!("  output {:<20} {}: {}", port.name, port.ty, port.doc);
        }
        for param in stage.params() {
            let default = match &param.default {
                None => "required".to_string(),
                Some(squeal_stages::Value::Str(text)) if text.is_empty() => "default \"\"".into(),
                Some(value) => format!("default {value}"),
            };
            let unit = if param.unit.is_empty() {
                String::new()
            } else {
                format!(" [{}]", param.unit)
            };
            println!(
                "  param  {:<20} {}{unit}, {default}: {}",
                param.name, param.ty, param.doc
            );
        }
    }
    ExitCode::SUCCESS
}
