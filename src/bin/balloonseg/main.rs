//! The `balloonseg` command line (SPEC §3).

fn main() {
    eprintln!("balloonseg: no commands yet");
    std::process::exit(2);
}
