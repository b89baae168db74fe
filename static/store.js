// The page's state, owned by this module: every other module imports it from here (no
// global). What a session shows (code, config, version, figure), the slider pump (busy,
// dirty, lastInput), the running job, what the server said once (caps, presets), and
// whether this page is the teacher's (teaching).

export const state = {
  code: null, config: null, fig: "loop", fitFigure: null, busy: false, dirty: false,
  presets: [], caps: null, events: null, job: null, lastInput: -Infinity, settle: null,
  teaching: false,  // this page pushes or leads the lesson (its own pushes are "you")
};
