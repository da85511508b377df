"""GidaBot's web layer: the shared web stack (:mod:`gidabot_web.web`) and the staff dashboard
(:mod:`gidabot_web.dashboard`)."""
