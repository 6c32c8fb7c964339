"""The network fits every study repeats, and the paper's MSE in arc-minutes squared.

The training algorithms minimise the mean squared error of the target scaled
to [-1, 1] (MATLAB's ``mapminmax``). The paper's MSE values (0.0083 for
trainlm) are in the target's own unit, arcmin^2: a normalised MSE is
converted by dividing by ``target_gain ** 2``.
"""

import time

import numpy as np

from ...training.network import ACTIVATIONS, NetworkProblem, encode_angles

__all__ = ["task_seed", "fit_network", "training_mse_arcmin2", "mse_history_arcmin2", "hidden_layer",
           "held_out_problem", "train_once"]


def task_seed(base_seed, *key):
    """A 32-bit seed for one fit, from the study's seed and the fit's identity (not its position).

    Examples
    --------
    >>> task_seed(0, 80, 1) == task_seed(0, 80, 1) != task_seed(0, 80, 2)
    True
    """
    return int(np.random.SeedSequence([int(base_seed), *[int(k) for k in key]]).generate_state(1)[0])


def fit_network(theta_deg, error_arcmin, *, hidden, algorithm="trainlm", encoding="raw", seed=0,
                **train_options):
    """A 1:N:1 network fitted with :func:`encal.models.ann.fit_ann` (MATLAB defaults otherwise)."""
    from ...models.ann import fit_ann

    return fit_ann(theta_deg, error_arcmin, hidden=int(hidden), algorithm=algorithm, encoding=encoding,
                   rng=seed, **train_options)


def training_mse_arcmin2(model, theta_deg, error_arcmin):
    """The paper's MSE: mean squared residual of ``model`` on its training points, arcmin^2."""
    residual = np.asarray(error_arcmin, dtype=float) - model.predict(theta_deg)
    return float(np.mean(residual**2))


def mse_history_arcmin2(model):
    """Training MSE after every epoch (epoch 0 first), converted from normalised units to arcmin^2."""
    gain = float(model.parameters()["target_gain"])
    return np.asarray(model.train_result.history["mse"], dtype=float) / gain**2


def held_out_problem(theta_deg, error_arcmin, test_theta_deg, test_error_arcmin, *, hidden, encoding,
                 activation="tansig"):
    """The training problem of the test points, scaled as a network trained on the training points scales.

    Its ``mse(w)`` is the test MSE (normalised units) of the network with weights ``w``.
    """
    train = NetworkProblem.from_angles(theta_deg, error_arcmin, hidden, encoding=encoding, activation=activation)
    return NetworkProblem.from_angles(test_theta_deg, test_error_arcmin, hidden, encoding=encoding,
                                      activation=activation, input_scaling=train.input_scaling,
                                      target_scaling=train.target_scaling)


def hidden_layer(model, theta_deg):
    """The hidden layer of a network at the given encoder angles, before and after its activation.

    Parameters
    ----------
    model : ANNModel
    theta_deg : array-like of shape (m,)
        Encoder angles in degrees.

    Returns
    -------
    before : ndarray of shape (m, N)
        Net inputs ``W1 x_n + b1`` of the N hidden nodes (the paper's X, "before the sigmoid").
    after : ndarray of shape (m, N)
        Their outputs ``f(W1 x_n + b1)``, the matrix whose SVD measures redundant nodes.
    """
    p = model.parameters()
    inputs = encode_angles(np.mod(np.asarray(theta_deg, dtype=float), 360.0), p["encoding"])
    normalised = np.asarray(p["input_gain"]) * (inputs - np.asarray(p["input_offset"])) - 1.0
    before = normalised @ np.asarray(p["W1"], dtype=float).reshape(len(p["b1"]), -1).T + np.asarray(p["b1"])
    activation = ACTIVATIONS[p.get("activation", "tansig")][0]
    return before, activation(before)


def train_once(task):
    """One fit of a study (runs in a worker process): its final MSE, epochs, stop reason, times and curves.

    Parameters
    ----------
    task : dict
        ``theta_deg``, ``error_arcmin`` (training points), ``hidden``, ``algorithm``, ``encoding``,
        ``seed``, ``epochs``, ``keep_curve`` (keep the MSE of every epoch), and optionally ``test``, a pair
        (encoder angles, errors) of test points. The test points never steer training; they are only
        measured, after every epoch when ``keep_curve``.

    Returns
    -------
    dict
        ``mse_arcmin2``, ``epochs``, ``reason``, ``time_s``, ``cpu_s``, ``curve`` (arcmin^2 per epoch or
        None) and, with test points, ``test_mse_arcmin2``, ``test_rms_arcmin`` and ``test_curve``.
    """
    options = {"epochs": task["epochs"]}
    test = task.get("test")
    test_curve = []
    if test is not None and task["keep_curve"]:
        # Measured through a callback, not as MATLAB's validation set: given one, training returns the weights
        # of the best validation epoch, and the test points would steer which network is reported.
        problem = held_out_problem(task["theta_deg"], task["error_arcmin"], *test, hidden=task["hidden"],
                               encoding=task["encoding"])
        options["callback"] = lambda epoch, w, mse: test_curve.append(problem.mse(w))
    start, cpu_start = time.perf_counter(), time.process_time()
    model = fit_network(task["theta_deg"], task["error_arcmin"], hidden=task["hidden"],
                        algorithm=task["algorithm"], encoding=task["encoding"], seed=task["seed"], **options)
    result = {
        "mse_arcmin2": training_mse_arcmin2(model, task["theta_deg"], task["error_arcmin"]),
        "epochs": int(model.train_result.epochs),
        "reason": model.train_result.reason,
        "time_s": time.perf_counter() - start,
        "cpu_s": time.process_time() - cpu_start,
        "curve": mse_history_arcmin2(model) if task["keep_curve"] else None,
    }
    if test is not None:
        theta, error = test
        result["test_mse_arcmin2"] = training_mse_arcmin2(model, theta, error)
        result["test_rms_arcmin"] = float(np.sqrt(result["test_mse_arcmin2"]))
        gain = float(model.parameters()["target_gain"])
        result["test_curve"] = np.asarray(test_curve) / gain**2 if task["keep_curve"] else None
    return result
