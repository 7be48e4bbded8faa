// vpremesh: command-line front end of the remeshing service.
#include <CLI/CLI.hpp>
#include <cstdio>

#include "commands.h"
#include "exit_codes.h"

int main(int argc, char** argv) {
  CLI::App app{"vpremesh: visual-perception-guided remeshing"};
  app.require_subcommand(1);
  const vpr::cli::Command local = vpr::cli::add_local_command(app);
  const vpr::cli::Command eval = vpr::cli::add_eval_command(app);
  const vpr::cli::Command compare = vpr::cli::add_compare_command(app);
  const vpr::cli::Command peers = vpr::cli::add_peers_command(app);
  const vpr::cli::Command field_sheet = vpr::cli::add_field_sheet_command(app);
#ifdef VPR_HAVE_SERVICE_CLIENT
  const vpr::cli::Command submit = vpr::cli::add_submit_command(app);
  const vpr::cli::Command status = vpr::cli::add_status_command(app);
  const vpr::cli::Command watch = vpr::cli::add_watch_command(app);
  const vpr::cli::Command cancel = vpr::cli::add_cancel_command(app);
  const vpr::cli::Command bench = vpr::cli::add_bench_command(app);
#endif
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : vpr::cli::kExitUsage;
  }
  if (app.got_subcommand("local")) return local();
  if (app.got_subcommand("eval")) return eval();
  if (app.got_subcommand("compare")) return compare();
  if (app.got_subcommand("peers")) return peers();
  if (app.got_subcommand("field-sheet")) return field_sheet();
#ifdef VPR_HAVE_SERVICE_CLIENT
  if (app.got_subcommand("submit")) return submit();
  if (app.got_subcommand("status")) return status();
  if (app.got_subcommand("watch")) return watch();
  if (app.got_subcommand("cancel")) return cancel();
  if (app.got_subcommand("bench")) return bench();
#endif
  return vpr::cli::kExitUsage;
}
