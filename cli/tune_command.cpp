#include "common.hpp"
namespace skinspec::cli {
void add_tune_command(CLI::App&) {}
}  // namespace skinspec::cli
