// Cooperative Ctrl-C: long commands poll interrupted() and finish cleanly (complete output
// files, committed atomically) instead of dying mid-write.
#pragma once

namespace spikems {

// Installs SIGINT/SIGTERM handlers that set a flag; a second signal exits at once.
void install_interrupt_flag();
bool interrupted();

}  // namespace spikems
