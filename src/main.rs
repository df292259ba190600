fn main() {
    eprintln!("nurbs-contact: command line being integrated");
}
