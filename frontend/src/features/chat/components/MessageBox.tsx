import { useState, type FormEvent } from 'react';
import { Button } from '@/components/ui/Button';
import { PushToTalk } from '@/features/voice/components/PushToTalk';
import { useChatStore } from '@/stores/chatStore';
import { sendMessage } from '../api/chat';

export function MessageBox() {
  const draft = useChatStore((s) => s.draft);
  const setDraft = useChatStore((s) => s.setDraft);
  const [error, setError] = useState<string | null>(null);
  const [sending, setSending] = useState(false);

  const submit = async (event: FormEvent) => {
    event.preventDefault();
    const text = draft.trim();
    if (!text || sending) return;
    setSending(true);
    setError(null);
    try {
      await sendMessage(text);
      setDraft('');
    } catch (err) {
      setError(`Not sent: ${err instanceof Error ? err.message : String(err)}`);
    } finally {
      setSending(false);
    }
  };

  return (
    <form onSubmit={submit} className="border-t border-line p-3">
      {error && (
        <p role="alert" className="mb-2 text-sm text-status-failed">
          {error}
        </p>
      )}
      <div className="flex items-center gap-2">
        <input
          aria-label="Message"
          value={draft}
          onChange={(e) => setDraft(e.target.value)}
          placeholder="Tell the robot what to do…"
          maxLength={4000}
          autoComplete="off"
          className="min-w-0 flex-1 rounded-md border border-line bg-canvas px-3 py-2 text-sm focus-visible:outline-2 focus-visible:outline-accent"
        />
        <Button type="submit" variant="primary" disabled={!draft.trim() || sending}>
          Send
        </Button>
        <PushToTalk />
      </div>
    </form>
  );
}
