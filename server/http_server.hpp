// The daemon's HTTP server: cpp-httplib 0.11's request processing behind its own front end.
//
// The library gives every connection a pool thread from accept to close, reads the request head
// with no bound on its time, its header count or its total size, and listens with a backlog of 5:
// 64 clients dripping header lines held every thread (and /healthz with them), a flood of headers
// grew the daemon by a gigabyte before the 401, and bursts of connects were reset. So HttpServer
// accepts on its own (backlog SOMAXCONN) and one thread reads every connection's head with epoll,
// bounded in size, field count and time; only a complete, well-framed head goes to a pool thread,
// and a kept-alive connection comes back to the front end between requests. Probes without a body
// have two threads of their own, so that uploads holding every pool thread cannot stall them.
//
// On the pool thread one stream serves the connection's request (cpp-httplib makes a new socket
// stream per request whose read-ahead was lost with it): what it read ahead stays for the next
// request, half-closed clients (shutdown(SHUT_WR)) are still written to, an answer that says
// `Connection: close` ends the connection, handlers learn their connection's socket, chunked bodies
// are checked against RFC 9112's grammar as they are read, and Range headers the library would
// refuse with a 416 before routing are hidden from it (see range_header).
#pragma once
#include <httplib.h>

#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

namespace hocurve::server {

/// What a client may send before its request reaches a pool thread; refused with a problem answer
/// and the connection closed.
struct FrontLimits {
  std::size_t head_bytes = 32 * 1024;     ///< request line and header fields together (431)
  std::size_t head_fields = 100;          ///< header fields (431)
  std::size_t line_bytes = 8 * 1024;      ///< the request line (414) or one field (431)
  double head_seconds = 10;               ///< a whole head, from its first byte or the connect (408)
  std::size_t buffered_bytes = 16u << 20; ///< incomplete heads of all connections together (503)
  std::size_t connections = 4096;         ///< connections between requests or reading a head (503)
};

class HttpServer : public httplib::Server {
 public:
  HttpServer();
  ~HttpServer() override;
  void set_front_limits(const FrontLimits& limits) { limits_ = limits; }
  /// Called (on the front end's thread) for each request the front end answers itself: the
  /// method if the request line got that far, and the status.
  void set_refusal_counter(std::function<void(const std::string& method, int status)> f) { on_refusal_ = std::move(f); }
  /// Serves the socket bound by bind_to_port / bind_to_any_port until halt(); requests run on
  /// new_task_queue's pool. False if it could not start.
  bool serve();
  /// Stops accepting, closes idle connections and returns from serve() once running requests end.
  void halt();

  struct Connection;

 private:
  void serve_connection(Connection* c);  // on a pool thread
  void give_back(Connection* c);         // from a pool thread to the front end
  FrontLimits limits_;
  std::function<void(const std::string&, int)> on_refusal_;
  std::unique_ptr<httplib::TaskQueue> task_queue_;
  std::unique_ptr<httplib::TaskQueue> probe_queue_;  // GET /healthz, /readyz, /metrics: never behind uploads
  int wake_fd_ = -1;
  std::atomic<bool> halted_{false};
  std::mutex returned_mutex_;
  std::vector<Connection*> returned_;
  friend class Front;
};

/// The socket of the connection whose request this thread is handling (-1 outside one).
int current_connection_socket();

/// Ends this thread's connection once the current answer is written, whatever its headers say
/// (the answer itself should carry `Connection: close`).
void close_connection_after_response();

/// True when this thread's request failed to read because the client stayed silent longer than the
/// read timeout (a stalled body: 408, not a malformed one's 400).
bool request_read_timed_out();

/// The request's Range header, or else the one this thread's connection kept from the library:
/// cpp-httplib 0.11 parses Range before any handler runs and answers 416 on every route to values
/// it cannot parse, valid ones ("BYTES=0-9") and those RFC 9110 says to ignore ("bytes=abc") alike;
/// HttpServer hides them from it. Empty if none.
std::string range_header(const httplib::Request& req);

/// RFC 9112 section 7.1's chunked framing, checked a byte at a time as the library reads a body:
/// 1*HEXDIG sizes (no sign, "0x" or blanks before them), extensions after ';', CRLF line ends, CRLF
/// after each chunk's data, trailer fields and the final empty line. The library's own parser
/// (strtoul, then any text) took "0x5", " 5", "-1" and bare LFs.
class ChunkedFraming {
 public:
  /// False once the bytes seen break the grammar (they stay broken).
  bool feed(const char* data, std::size_t n);
  bool done() const { return state_ == kDone; }

 private:
  enum State { kSize, kSizeBlank, kExt, kSizeLf, kData, kDataCr, kDataLf, kFieldStart, kField, kFieldLf, kLastLf, kDone, kBad };
  State state_ = kSize;
  unsigned long long left_ = 0;
  int digits_ = 0;
  std::size_t trailer_bytes_ = 0;
};

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
