"""A small, hardened web stack on aiohttp (ROS-free, dashboard-free): login and sessions, CSRF and
same-origin checks, rate limits, security headers, request size limits, files served only by the names
an application lists, and live updates over WebSocket. The staff dashboard and the building editor
build on it (docs/dashboard.md, *The web stack*)."""
