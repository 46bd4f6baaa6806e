//! The `nekosim` command (see [`nekosim::cli`]): the built-in protocols and algorithms.

#[global_allocator]
static GLOBAL: nekosim::allocator::MiMalloc = nekosim::allocator::MiMalloc;

fn main() -> std::process::ExitCode {
    nekosim::cli::main_with(nekosim::scenario::Registry::with_builtins())
}
