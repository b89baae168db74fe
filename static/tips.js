// ---------------------------------------------------------------- tooltips
import { VIEW_HELP } from "/view.js";

// Every control says what it does when the pointer rests on it (title); a control that
// brings its own title keeps it. Sliders built later (per operator) are covered too.
const TIPS = {
  "join-code": "The code of a session to continue (shown at the top of the page that uses it)",
  join: "Continue the session whose code you typed",
  "new-session": "Start a fresh session (the current one stays on the server under its code)",
  "my-name": "Shown in the teacher's list of who is connected; your session code is not",
  projector: "Projector mode: the plot's text and the help at least 16 px, to read from the back of a room",
  preset: "Models and inputs taken from the papers' examples",
  "load-preset": "Replace the model and the input by the chosen preset's",
  n: "Number of play operators; thresholds are spread evenly up to the widest, the total weight shared",
  "model-json": "The session's model as JSON: any model type, edited by hand",
  "apply-json": "Use the model typed in the JSON box",
  kind: "Shape of the input signal u(t)",
  amplitude: "Peak value of the input (in the input's unit)",
  frequency: "Cycles per second of the input",
  offset: "Value the input oscillates around",
  duration: "Length of the simulated input",
  samples: "Number of time steps simulated (more: smoother curves, slower)",
  "use-recording": "Drive the model with the uploaded recording's input instead of the signal above",
  mismatch: "Makes the real plant differ from the model: thresholds ×(1+m), weights ×(1−m)",
  "csv-file": "A CSV file with time, input and output columns (any delimiter, decimal comma allowed)",
  "t-col": "The column holding the time stamps",
  "u-col": "The column holding the input (what drove the actuator)",
  "y-col": "The column holding the output (what was measured)",
  "timing-resample": "Interpolate the samples onto evenly spaced time stamps (the step shown)",
  "timing-keep": "Use the time stamps as they are in the file",
  "use-csv": "Load the recording with this column mapping",
  "run-pick": "Which run of the file to use, every run as its own loop (fitted together), or all rows as one recording",
  "fit-kind": "Which model type the fit identifies",
  "fit-n": "Number of operators of the fitted model",
  fit: "Fit the chosen model to the recording (it replaces the session's model)",
  diagnose: "Find what the PI model misses in the recording, proved on rows the fit never saw",
  "cancel-job": "Stop the fit or diagnosis; nothing is changed",
  "dl-json": "Download the model as a parameter set (JSON) to continue later",
  "dl-mat": "Download the model for MATLAB / Octave",
  "dl-c": "Download C code of the model and its inverse for a controller",
  "ps-file": "Load a parameter set saved earlier (JSON)",
  "fmi-version": "Which FMI standard the FMU downloads follow (3.0, or 2.0 for older tools)",
  "lesson-new-lesson": "The title of the lesson you are making",
  "lesson-new-title": "The title of the step to add (the current model, input and view)",
  "lesson-new-prompt": "What the class is asked at this step",
  "lesson-new-look": "What the students should look for in the plot",
  "teacher-token": "The token the server was started with (hyst serve --teacher-token)",
  "teacher-preset": "The preset every student gets",
  "teacher-input": "Which input every student gets with it",
  "teacher-push": "Send the chosen model to every student's page now",
  "teacher-push-mine": "Send the model of this page (as you edited it) to every student now",
  "teacher-refresh": "How many pages are open and the names students gave (never their codes)",
  "digi-prev": "One state back along the trace",
  "digi-next": "One state forward along the trace",
  "digi-play": "Walk through the states the input visits, two per second",
  "digi-step": "Which state of the trace the diagram shows",
};
// (the model's sliders carry theirs on their label, from the fields' declarations)
export function addTips(root = document) {
  for (const e of root.querySelectorAll("input, select, button, textarea, a.button")) {
    if (e.closest("[title]")) continue;
    // a number box beside a slider says what its slider says, and that it takes exact values
    const tip = TIPS[e.id] || (e.dataset.fig && VIEW_HELP[e.dataset.fig])
      || (e.dataset.for && TIPS[e.dataset.for] && `${TIPS[e.dataset.for]}; type an exact value`);
    if (tip) e.title = tip;
  }
}
