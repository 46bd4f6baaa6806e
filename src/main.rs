fn main() {
    let p = std::env::args().nth(1).unwrap();
    match nekosim::scenario::Source::load(std::path::Path::new(&p)) {
        Err(e) => println!("{e}"),
        Ok(s) => match s.build(Default::default(), &Default::default()) {
            Err(e) => println!("{e}"),
            Ok(b) => println!("ok {} robots", b.robots.len()),
        },
    }
}
