fn main() {
    std::process::exit(toolpath_planner::cli::run_guarded());
}
