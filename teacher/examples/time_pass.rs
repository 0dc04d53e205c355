//! The teacher's time per pass and per labelling photo on this machine.
//! `cargo run --release -p teacher --example time_pass`
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let teacher = teacher::Teacher::shipped()?;
    let sq = vec![[120u8, 130, 110]; 416 * 416];
    teacher.raw(&sq)?;
    let t = std::time::Instant::now();
    for _ in 0..5 {
        teacher.raw(&sq)?;
    }
    println!("one pass: {:.1} ms", t.elapsed().as_secs_f64() * 200.0);
    Ok(())
}
