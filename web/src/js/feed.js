// The WebSocket to the simulator: reconnects by itself (the simulator may restart), hands each
// JSON message to a handler, and sends commands with an id so replies can be matched.
export class Feed {
  constructor(url, { onMessage, onStatus }) {
    this.url = url;
    this.onMessage = onMessage;
    this.onStatus = onStatus;
    this.nextId = 1;
    this.pending = new Map();
    this.delayMs = 250;
    this.connect();
  }

  connect() {
    // after a loss the page stays "offline" until the simulator is back
    if (!this.wasLive) this.onStatus('connecting');
    let ws;
    try {
      ws = new WebSocket(this.url);
    } catch (e) {
      this.retry();
      return;
    }
    this.ws = ws;
    ws.onopen = () => {
      this.delayMs = 250;
      this.wasLive = true;
      this.onStatus('live');
    };
    ws.onmessage = (ev) => {
      let msg;
      try {
        msg = JSON.parse(ev.data);
      } catch (e) {
        console.warn('feed: not JSON', e);
        return;
      }
      if ((msg.type === 'reply' || msg.type === 'image') && msg.id !== undefined) {
        const done = this.pending.get(msg.id);
        if (done) {
          this.pending.delete(msg.id);
          done(msg);
        }
      }
      this.onMessage(msg);
    };
    ws.onclose = () => {
      if (this.ws !== ws) return;
      this.ws = null;
      for (const done of this.pending.values()) done({ type: 'reply', ok: false, error: 'connection lost' });
      this.pending.clear();
      this.onStatus('down');
      this.retry();
    };
    // an error is always followed by close; the browser already logs it
    ws.onerror = () => {};
  }

  retry() {
    setTimeout(() => this.connect(), this.delayMs);
    this.delayMs = Math.min(this.delayMs * 2, 2000);
  }

  // Sends a command; resolves with its reply (or image) message.
  request(command) {
    return new Promise((resolve) => {
      if (!this.ws || this.ws.readyState !== WebSocket.OPEN) {
        resolve({ type: 'reply', ok: false, error: 'not connected to the simulator' });
        return;
      }
      const id = this.nextId++;
      this.pending.set(id, resolve);
      this.ws.send(JSON.stringify({ ...command, id }));
    });
  }
}
