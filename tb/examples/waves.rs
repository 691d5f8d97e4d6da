//! Regenerates the example waves: `cargo run -p tb --example waves [DIR]` (default `waves`).

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args().nth(1).unwrap_or_else(|| "waves".to_string());
    for path in tb::run::waves::write_examples(dir.as_ref())? {
        println!("{} (+ .gtkw)", path.display());
    }
    Ok(())
}
