// Starting a child process of a load tool (mdr_fairness's alice, mdr_load's stream clients), so
// that a client's CPU time competes with the server as it would from another machine.
#pragma once

#include <spawn.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

extern char** environ;

namespace mdr::bench {

// Starts `command` (argv[0] a path). output != nullptr: its stdout and stderr go to a pipe whose
// read end is *output. input != nullptr: its stdin comes from a pipe whose write end is *input
// (closing it gives the child end of file). Throws std::runtime_error if it cannot start.
inline pid_t Spawn(const std::vector<std::string>& command, int* output, int* input = nullptr) {
  int out_fds[2] = {-1, -1}, in_fds[2] = {-1, -1};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (output != nullptr) {
    if (pipe(out_fds) != 0) throw std::runtime_error("pipe: " + std::string(std::strerror(errno)));
    posix_spawn_file_actions_adddup2(&actions, out_fds[1], STDERR_FILENO);
    posix_spawn_file_actions_adddup2(&actions, out_fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, out_fds[0]);
  }
  if (input != nullptr) {
    if (pipe(in_fds) != 0) throw std::runtime_error("pipe: " + std::string(std::strerror(errno)));
    posix_spawn_file_actions_adddup2(&actions, in_fds[0], STDIN_FILENO);
    posix_spawn_file_actions_addclose(&actions, in_fds[1]);
  }
  std::vector<char*> argv;
  for (const std::string& word : command) argv.push_back(const_cast<char*>(word.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int error = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (error != 0) {
    throw std::runtime_error("cannot start " + command[0] + ": " + std::strerror(error));
  }
  if (output != nullptr) {
    close(out_fds[1]);
    *output = out_fds[0];
  }
  if (input != nullptr) {
    close(in_fds[0]);
    *input = in_fds[1];
  }
  return pid;
}

}  // namespace mdr::bench
