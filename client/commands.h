// Subcommands of the vpremesh CLI. Each registers its options on the app and
// returns the function that runs it (an exit code from exit_codes.h).
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace vpr::cli {

using Command = std::function<int()>;

Command add_local_command(CLI::App& app);
Command add_eval_command(CLI::App& app);
Command add_compare_command(CLI::App& app);  // compare_command.cpp: ours against the peers
Command add_peers_command(CLI::App& app);    // peers_command.cpp: the peers' meshes, for scripts/quality.sh
Command add_field_sheet_command(CLI::App& app);  // field_sheet_command.cpp: a mesh coloured by fields, one PNG

#ifdef VPR_HAVE_SERVICE_CLIENT
// The service (submit_command.cpp, job_commands.cpp): jobs on a vpremesh-server.
Command add_submit_command(CLI::App& app);
Command add_status_command(CLI::App& app);
Command add_watch_command(CLI::App& app);
Command add_cancel_command(CLI::App& app);
// bench_command.cpp: load and latency of a server (closed or open loop).
Command add_bench_command(CLI::App& app);
#endif

}  // namespace vpr::cli
