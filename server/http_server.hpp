// The daemon's HTTP server: cpp-httplib 0.11's Server with its own connection loop.
//
// The library makes a new socket stream for every request of a keep-alive connection, and each
// stream reads up to 4 KiB ahead: requests pipelined behind the first (written at once, before
// reading) were read into the first stream and dropped with it, so only the first was answered.
// Its stream also refuses to write to a client that half-closed (shutdown(SHUT_WR)) after a
// complete request. HttpServer keeps one stream per connection (what it read ahead stays for the
// next request), writes to half-closed clients, ends the connection after any answer that says
// `Connection: close`, tells handlers their connection's socket, and hides from the library the
// Range headers it would refuse with a 416 before routing (see range_header).
#pragma once
#include <httplib.h>

namespace hocurve::server {

class HttpServer : public httplib::Server {
 private:
  bool process_and_close_socket(socket_t sock) override;
};

/// The socket of the connection whose request this thread is handling (-1 outside one, or under
/// a plain httplib::Server).
int current_connection_socket();

/// Ends this thread's connection once the current answer is written, whatever its headers say
/// (the answer itself should carry `Connection: close`).
void close_connection_after_response();

/// The request's Range header, or else the one this thread's connection kept from the library:
/// cpp-httplib 0.11 parses Range before any handler runs and answers 416 on every route to values
/// it cannot parse, valid ones ("BYTES=0-9") and those RFC 9110 says to ignore ("bytes=abc") alike;
/// HttpServer hides them from it. Empty if none.
std::string range_header(const httplib::Request& req);

/// Tells a client that closed or reset its connection from one that only half-closed it after
/// sending its whole request (legal HTTP). Both send a FIN, seen as POLLRDHUP; only a closed socket
/// answers data with a reset. So the first FIN is answered with an interim `100 Continue` (HTTP/1.1
/// clients must accept 1xx responses before the final one; none is sent to HTTP/1.0 clients, whose
/// FIN counts as gone) and the client is gone once the reset arrives (POLLHUP/POLLERR).
class PeerWatch {
 public:
  /// `fd` < 0: never gone. `http11`: the request was HTTP/1.1, so a 1xx probe may be sent.
  PeerWatch(int fd, bool http11) : fd_(fd), http11_(http11) {}
  /// True once the client is known to have closed or reset the connection. Returns at once, or
  /// after at most 100 ms while a probe's answer is awaited.
  bool gone();

 private:
  int fd_;
  bool http11_;
  bool probed_ = false;
};

}  // namespace hocurve::server
