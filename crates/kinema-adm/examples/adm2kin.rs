//! Prints an ADM file as `.kin` (what `kinema import` will do), or its errors.
//!
//! `cargo run -p kinema-adm --example adm2kin -- model.adm`

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: adm2kin MODEL.adm");
        std::process::exit(2);
    };
    match kinema_adm::Model::read(std::path::Path::new(&path)) {
        Ok((model, source)) => {
            if !model.warnings.is_empty() {
                let warnings = model.warnings.report(source.into());
                eprint!("{}", warnings.render());
            }
            print!("{}", kinema_adm::to_kin(&model));
        }
        Err(report) => {
            eprint!("{}", report.render());
            std::process::exit(2);
        }
    }
}
