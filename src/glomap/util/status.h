// Errors as values: every stage that can fail on user data returns a Status
// instead of aborting, so that the command and the GUI can report one clear
// line (see ../shared/STYLE.md, "Errors are values at the edges").
#pragma once

#include <algorithm>
#include <exception>
#include <functional>
#include <new>
#include <string>
#include <system_error>
#include <utility>

namespace glomap {

class Status {
 public:
  static Status Ok() { return Status(); }
  // The run was stopped by the user (GUI cancel); not an error in the data.
  static Status Cancelled() {
    Status status = Error("Stopped by the user.");
    status.cancelled_ = true;
    return status;
  }
  static Status Error(std::string message) {
    Status status;
    status.ok_ = false;
    status.message_ = std::move(message);
    return status;
  }

  bool ok() const { return ok_; }
  bool cancelled() const { return cancelled_; }
  const std::string& message() const { return message_; }

 private:
  bool ok_ = true;
  bool cancelled_ = false;
  std::string message_;
};

// The error for std::bad_alloc.
constexpr char kOutOfMemoryMessage[] =
    "Out of memory: the run needs more memory than this machine (or its "
    "memory limit) allows.";

// The one-line error for the exception being handled; call it only inside a
// catch block. Exceptions never stand for a problem in the user's data (that
// is a Status from the stage that found it): they mean the machine ran out of
// memory, or a bug. The command and the GUI catch every exception at their
// edge and report it through this, instead of terminating.
inline Status StatusFromCurrentException() {
  try {
    throw;
  } catch (const std::bad_alloc&) {
    return Status::Error(kOutOfMemoryMessage);
  } catch (const std::exception& e) {
    const auto* system_error = dynamic_cast<const std::system_error*>(&e);
    if (system_error != nullptr &&
        system_error->code() == std::errc::resource_unavailable_try_again) {
      // What std::thread throws when the system refuses a new thread.
      return Status::Error(
          "Out of resources: the system refused a new thread (" +
          std::string(e.what()) + "); free memory or raise the limits.");
    }
    std::string what = e.what();
    std::replace(what.begin(), what.end(), '\n', ' ');
    return Status::Error("Internal error: " + what +
                         " (an unexpected exception; please report it).");
  } catch (...) {
    return Status::Error(
        "Internal error: an unexpected exception of unknown type (please "
        "report it).");
  }
}

// Lets a long stage stop promptly when the user cancels: stages poll
// IsStopped() between steps and from Ceres iteration callbacks, and return
// Status::Cancelled().
struct Interrupt {
  std::function<bool()> is_stopped;

  bool IsStopped() const { return is_stopped && is_stopped(); }
};

}  // namespace glomap
