// Throwaway (not committed): compares the pixel data of pairs of EXR files bit for bit.
use std::path::Path;
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    for pair in args.chunks(2) {
        let a = coatlab_core::io::exr_read::read_exr(Path::new(&pair[0])).expect("a");
        let b = coatlab_core::io::exr_read::read_exr(Path::new(&pair[1])).expect("b");
        let same = a.width() == b.width() && a.height() == b.height()
            && a.pixels().iter().zip(b.pixels()).all(|(p, q)| p.iter().zip(q).all(|(x, y)| x.to_bits() == y.to_bits()));
        println!("{} {}", if same { "same-pixels" } else { "DIFF-pixels" }, pair[0]);
    }
}
